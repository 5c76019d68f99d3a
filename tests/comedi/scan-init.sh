#!/bin/sh
# /init of the guest that runs a fly scan with its trigger on a DAQ card's
# digital output: comedi_parport attached to /dev/comedi0 (qemu's parallel
# port), `piezo scan` (here /check) with tests/comedi/scan.toml and the
# calibration the host made for it, and a watcher of the port's data line 2.
# The summary, the log and the edges go out on the second serial port as
# base64 for the host; the exit code to the console.
mount -t proc none /proc
mount -t sysfs none /sys
mount -t devtmpfs none /dev
source=/sys/devices/system/clocksource/clocksource0/current_clocksource
for i in $(seq 1 100); do
  [ "$(cat $source)" = tsc ] && break
  sleep 0.1
done
if [ "$(cat $source)" != tsc ]; then
  echo "comedi-scan: no tsc clock ($(cat $source))"
  reboot -f
fi
/trigger_watch attach /dev/comedi0 || echo "comedi-scan: cannot attach comedi_parport"
mkdir -p /tmp /runs
mount -t tmpfs none /runs
/trigger_watch watch /dev/comedi0 2 /edges.txt &
watcher=$!
/check scan --config /scan.toml --set piezod.calibration_file=/calibration.json \
  --from 0.01 --to 0.05 --velocity 0.02 --trigger-step 0.001 --trigger-width 0.01 \
  --out /runs/scan --json > /summary.json
status=$?
kill $watcher
wait $watcher
cat /summary.json
stty -F /dev/ttyS1 raw
{
  echo "summary"; base64 /summary.json
  echo "log"; base64 /runs/scan/run.h5
  echo "edges"; base64 /edges.txt
  echo "end"
} > /dev/ttyS1
echo "comedi-scan exit code: $status"
reboot -f
