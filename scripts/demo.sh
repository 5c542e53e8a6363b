#!/usr/bin/env bash
# liloc demo: installs what is missing, builds, and runs what exists end to end.
# Today: the foundation. liloc writes a log with one message of every type, lcm-logplayer
# plays it over loopback UDP multicast, lcm-logger records it, and liloc_log decodes the
# recording (types, rates, decode errors, sequence gaps).
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
echo
echo "Browse live traffic with ./scripts/spy.sh (lcm-spy with liloc's types)."
