#!/bin/sh
# /init of the guest that runs a fly scan with its trigger on the kernel's
# gpio-sim chip: `piezo scan` (here /check) with tests/gpio-sim/scan.toml,
# the calibration the host made for it, and an edge watcher on the trigger
# line's sysfs value. The summary, the log and the edges go out on the
# second serial port as base64 for the host; the exit code to the console.
mount -t proc none /proc
mount -t sysfs none /sys
mount -t devtmpfs none /dev
mount -t configfs none /sys/kernel/config
source=/sys/devices/system/clocksource/clocksource0/current_clocksource
for i in $(seq 1 100); do
  [ "$(cat $source)" = tsc ] && break
  sleep 0.1
done
if [ "$(cat $source)" != tsc ]; then
  echo "gpio-scan: no tsc clock ($(cat $source))"
  reboot -f
fi
bank=/sys/kernel/config/gpio-sim/rig
mkdir "$bank" "$bank/bank0"
echo 16 > "$bank/bank0/num_lines"
echo 1 > "$bank/live"
chip=$(cat "$bank/bank0/chip_name")
device=$(cat "$bank/dev_name")
echo "gpio-scan: $chip on $device"
mkdir -p /tmp /runs
mount -t tmpfs none /runs
/edge_watch "/sys/devices/platform/$device/$chip/sim_gpio13/value" /edges.txt &
watcher=$!
/check scan --config /scan.toml --set lines.gpiod.chip="$chip" \
  --set piezod.calibration_file=/calibration.json \
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
echo "gpio-scan exit code: $status"
reboot -f
