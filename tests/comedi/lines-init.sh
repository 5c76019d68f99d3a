#!/bin/sh
# /init of the guest for the lines on a DAQ card's digital I/O: one legacy
# Comedi minor (/dev/comedi0, which the check configures as comedi_parport
# on qemu's parallel port) before comedi_test's card (/dev/comedi1); the
# exit code goes to the console, and the guest powers off.
mount -t proc none /proc
mount -t sysfs none /sys
mount -t devtmpfs none /dev
source=/sys/devices/system/clocksource/clocksource0/current_clocksource
for i in $(seq 1 100); do
  [ "$(cat $source)" = tsc ] && break
  sleep 0.1
done
echo "comedi-lines: $(ls /dev/comedi*)"
/check
echo "comedi-lines exit code: $?"
reboot -f
