#!/bin/sh
# /init of the gpio-sim guest: a 16-line gpio-sim bank through configfs,
# then the project's check program against it; the exit code goes to the
# console, and the guest powers off (qemu runs with -no-reboot).
mount -t proc none /proc
mount -t sysfs none /sys
mount -t devtmpfs none /dev
mount -t configfs none /sys/kernel/config
# High-resolution timers start only once the refined TSC clocksource has
# replaced tsc-early (about a second after boot); before that, sleeps are
# rounded to the 4 ms tick.
source=/sys/devices/system/clocksource/clocksource0/current_clocksource
for i in $(seq 1 100); do
  [ "$(cat $source)" = tsc ] && break
  sleep 0.1
done
echo "gpio-sim: clocksource $(cat $source)"
bank=/sys/kernel/config/gpio-sim/rig
mkdir "$bank" "$bank/bank0"
echo 16 > "$bank/bank0/num_lines"
echo 1 > "$bank/live"
chip=$(cat "$bank/bank0/chip_name")
device=$(cat "$bank/dev_name")
echo "gpio-sim: $chip on $device"
/check "$chip" "/sys/devices/platform/$device/$chip"
echo "gpio-sim exit code: $?"
reboot -f
