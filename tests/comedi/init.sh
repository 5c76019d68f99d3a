#!/bin/sh
# /init of the comedi guest: the kernel's comedi_test card is /dev/comedi0
# (built in, configured at boot, its waveforms set on the kernel command
# line); the project's check program runs against it with the driver's own
# amplitude and period; the exit code goes to the console, and the guest
# powers off (qemu runs with -no-reboot).
mount -t proc none /proc
mount -t sysfs none /sys
mount -t devtmpfs none /dev
# High-resolution timers start only once the refined TSC clocksource has
# replaced tsc-early (about a second after boot).
source=/sys/devices/system/clocksource/clocksource0/current_clocksource
for i in $(seq 1 100); do
  [ "$(cat $source)" = tsc ] && break
  sleep 0.1
done
parameters=/sys/module/comedi_test/parameters
echo "comedi: $(ls /dev/comedi0) amplitude $(cat $parameters/amplitude) uV period $(cat $parameters/period) us"
/check "$(cat $parameters/amplitude)" "$(cat $parameters/period)"
echo "comedi exit code: $?"
reboot -f
