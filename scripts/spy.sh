#!/usr/bin/env bash
# Starts lcm-spy with liloc's types on the classpath, so that every channel is decoded.
# Debian's lcm-spy wrapper ignores CLASSPATH and passes -Xincgc, which Java 17 refuses;
# this starts the same main class directly.
#   ./scripts/spy.sh [--lcm-url URL]    (default: liloc's loopback URL)
set -euo pipefail
cd "$(dirname "$0")/.."
JAR=${LILOC_BUILD_DIR:-build}/lcmtypes/liloc_types.jar
if [[ ! -f "$JAR" ]]; then
  echo "spy.sh: $JAR is missing; run ./scripts/build.sh first" >&2
  exit 1
fi
URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
if [[ $# -ge 2 && "$1" == "--lcm-url" ]]; then
  URL=$2
  shift 2
fi
CP="$(realpath "$JAR"):/usr/share/java/lcm.jar:/usr/share/java/jchart2d.jar"
exec java -server -Djava.net.preferIPv4Stack=true -Xmx512m -cp "$CP" lcm.spy.Spy \
  --lcm-url="$URL" "$@"
