// Decodes every event of an LCM log the way lcm-spy does: it finds each message's type
// by fingerprint among the classes on the classpath (lcm.spy.LCMTypeDatabase, which
// scans the jars in java.class.path) and constructs it from the bytes.
//
//   java -cp liloc_types.jar:lcm.jar SpyDecodeCheck.java LOG EXPECTED_TYPES
//
// Prints one line per channel and exits non-zero if any event fails to decode or if
// fewer than EXPECTED_TYPES distinct liloc types were decoded.

import java.io.IOException;
import java.lang.reflect.Constructor;
import java.util.Map;
import java.util.TreeMap;
import java.util.TreeSet;

public class SpyDecodeCheck {
  public static void main(String[] args) throws Exception {
    lcm.logging.Log log = new lcm.logging.Log(args[0], "r");
    int expectedTypes = Integer.parseInt(args[1]);
    lcm.spy.LCMTypeDatabase db = new lcm.spy.LCMTypeDatabase();
    Map<String, Integer> decoded = new TreeMap<>();
    Map<String, String> typeOfChannel = new TreeMap<>();
    TreeSet<String> types = new TreeSet<>();
    int failures = 0;
    while (true) {
      lcm.logging.Log.Event event;
      try {
        event = log.readNext();
      } catch (IOException endOfLog) {
        break;
      }
      long fingerprint = 0;
      for (int i = 0; i < 8; i++) {
        fingerprint = (fingerprint << 8) | (event.data[i] & 0xff);
      }
      Class<?> cls = db.getClassByFingerprint(fingerprint);
      if (cls == null) {
        System.out.println("NO TYPE for channel " + event.channel);
        failures++;
        continue;
      }
      Constructor<?> ctor = cls.getConstructor(byte[].class);
      ctor.newInstance((Object) event.data);
      decoded.merge(event.channel, 1, Integer::sum);
      typeOfChannel.put(event.channel, cls.getName());
      types.add(cls.getName());
    }
    for (Map.Entry<String, Integer> e : decoded.entrySet()) {
      System.out.printf("%-40s %-28s %d decoded%n", e.getKey(), typeOfChannel.get(e.getKey()),
                        e.getValue());
    }
    System.out.println(types.size() + " types decoded: " + types);
    if (failures > 0 || types.size() < expectedTypes) {
      System.out.println("FAILED: " + failures + " undecodable events, " + types.size() + " of "
                         + expectedTypes + " types");
      System.exit(1);
    }
  }
}
