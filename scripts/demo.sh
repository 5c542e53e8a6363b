#!/usr/bin/env bash
# liloc demo: installs what is missing, builds, and runs what exists end to end:
#  1-3. the message layer: a log with every liloc type goes through lcm-logplayer, loopback
#       UDP multicast and lcm-logger, and liloc_log decodes the recording;
#  4.   a simulated campus (HDL-32E), sessions A and B (routes shortened by
#       LILOC_DEMO_SCALE, default 0.3);
#  5.   the central session: liloc_map build on session A, ATE against ground truth;
#  6.   liloc_odometry on session B's log, scored by liloc_eval (the accuracy table);
#  7.   liloc_map_server serving the map to 4 robots over loopback (bench_mapserver);
#  8.   session B localized against the map in one process (bench_efg: initializer, then
#       the egocentric factor graph), beside the odometry alone;
#  9.   the system as processes over loopback UDP: map server, odometry replaying session B,
#       initializer (no coarse pose) and optimizer; its robot0.POSE recorded and scored, and
#       B's stretch outside the map merged into the map as a new version (MAP.UPDATE).
# Not yet in it: several robots localizing at once.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/build.sh >/dev/null
BIN=${LILOC_BUILD_DIR:-build}
OUT=${LILOC_DEMO_DIR:-data/demo}
mkdir -p "$OUT"
URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"

echo "== 1. a log with every liloc message type"
"$BIN"/bin/liloc_log sample "$OUT/sample.lcmlog" --log-level warn

echo "== 2. lcm-logplayer -> loopback multicast -> lcm-logger"
rm -f "$OUT/recorded.lcmlog"
lcm-logger -f --lcm-url="$URL" "$OUT/recorded.lcmlog" >/dev/null &
LOGGER=$!
trap 'kill $LOGGER 2>/dev/null || true' EXIT
sleep 0.5
lcm-logplayer --lcm-url="$URL" -s 1 "$OUT/sample.lcmlog" >/dev/null
sleep 0.5
kill -INT $LOGGER
wait $LOGGER 2>/dev/null || true
trap - EXIT

echo "== 3. what liloc_log decodes from the recording"
"$BIN"/bin/liloc_log info "$OUT/recorded.lcmlog"

SCALE=${LILOC_DEMO_SCALE:-0.3}
SIM="$OUT/sim"
SESSION_A="$SIM/campus/hdl32/A"
SESSION_B="$SIM/campus/hdl32/B"
echo
echo "== 4. simulate campus sessions A and B (HDL-32E, route length x$SCALE)"
if [ ! -f "$SESSION_B/session.lcmlog" ]; then
  "$BIN"/bin/liloc_sim --out "$SIM" --lidar hdl32 --sessions A,B --length-scale "$SCALE" \
    --log-level warn
fi

echo
echo "== 5. the central session: map from session A"
rm -rf "$OUT/map"
"$BIN"/bin/liloc_map build "$SESSION_A/session.lcmlog" "$OUT/map" \
  --ground-truth "$SESSION_A/ground_truth.tum" --json "$OUT/map_report.json" --log-level warn
"$BIN"/bin/liloc_map render "$OUT/map" "$OUT/map.png" --log-level warn

echo
echo "== 6. LiDAR-inertial odometry on session B (a process reading the log)"
rm -f "$OUT/odometry_B.lcmlog"
"$BIN"/bin/liloc_odometry --lcm-url "file://$PWD/$SESSION_B/session.lcmlog?speed=0" \
  --publish-url "file://$PWD/$OUT/odometry_B.lcmlog?mode=w" --log-level warn
"$BIN"/bin/liloc_eval "$SESSION_B/ground_truth.tum" "$OUT/odometry_B.lcmlog" \
  --est-channel robot0.ODOM --status-channel robot0.STATUS.odometry --name "odometry B" \
  --out "$OUT/odometry_B" --log-level warn

echo
echo "== 7. the map server answering 4 robots at 10 Hz over loopback"
"$BIN"/bin/bench_mapserver "$OUT/map" --server "$BIN/bin/liloc_map_server" --scales 1 \
  --robots 4 --duration-s 5 --json "" --log-level warn

echo
echo "== 8. session B localized against the map of A, in one process: the initializer (coarse"
echo "   pose 3 m off), then the egocentric factor graph; beside it the odometry alone"
"$BIN"/bin/bench_efg --data "$SIM" --maps "$OUT/map" --lidars hdl32 --sessions B \
  --variants full,ilm_only --json "" --log-level warn
echo
echo "== 9. the system as processes over loopback UDP: liloc_map_server, liloc_initializer and"
echo "   liloc_optimizer listen; liloc_odometry replays session B's log at its own pace; the"
echo "   optimizer's robot0.POSE (map frame) is recorded by lcm-logger and scored"
BUS="udpm://239.255.76.68:7668?ttl=0&recv_buf_size=4194304"  # a bus of its own
rm -f "$OUT/system_B.lcmlog"
PIDS=()
trap 'kill "${PIDS[@]}" 2>/dev/null || true' EXIT
"$BIN"/bin/liloc_map_server --map "$OUT/map" --lcm-url "$BUS" --log-level warn &
PIDS+=($!)
"$BIN"/bin/liloc_initializer --lcm-url "$BUS" --log-level warn &
PIDS+=($!)
"$BIN"/bin/liloc_optimizer --lcm-url "$BUS" --log-level warn &
PIDS+=($!)
lcm-logger -q --lcm-url="$BUS" -c 'robot0\.(POSE|INIT|STATUS\..*)' "$OUT/system_B.lcmlog" &
PIDS+=($!)
sleep 1
"$BIN"/bin/liloc_odometry --lcm-url "file://$PWD/$SESSION_B/session.lcmlog?speed=1" \
  --publish-url "$BUS" --log-level warn
sleep 2
kill -INT "${PIDS[@]}"
wait "${PIDS[@]}" 2>/dev/null || true
trap - EXIT
"$BIN"/bin/liloc_eval "$SESSION_B/ground_truth.tum" "$OUT/system_B.lcmlog" \
  --est-channel robot0.POSE --status-channel robot0.STATUS.optimizer \
  --name "system B (robot0.POSE)" --out "$OUT/system_B" --log-level warn
echo "   the map after session B (its ILM stretch merged as a new version):"
"$BIN"/bin/liloc_map inspect "$OUT/map" --log-level warn

echo
echo "Results in $OUT: map.png, odometry_B.png/.md/.json, system_B.png/.md/.json, map_report.json."
echo "Browse live traffic with ./scripts/spy.sh (lcm-spy with liloc's types)."
