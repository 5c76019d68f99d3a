#!/bin/sh
# /init of the guest that runs the paper's rig (configs/daq.toml) on the
# kernel's comedi_test card with the project's own `piezo run` (here
# /check): the card's AO 0 drives, its AI 0 (the driver's sawtooth) stands
# for the laser sensor. What differs from the file is what this card and
# an emulated machine need, given as --set: the drive loop at 2 kHz (the
# whole loop under software emulation keeps no more), a 50 ms preload
# (comedi_test's output timer takes a kernel tick's samples at once), and
# the sensor's span around 0 V, since the driver's sawtooth swings +/-4 V.
# The log and the JSON summary go out on the second serial port as base64
# for the host to read with h5py; the exit code goes to the console.
mount -t proc none /proc
mount -t sysfs none /sys
mount -t devtmpfs none /dev
source=/sys/devices/system/clocksource/clocksource0/current_clocksource
for i in $(seq 1 100); do
  [ "$(cat $source)" = tsc ] && break
  sleep 0.1
done
# The drive loop's deadlines need the TSC: on jiffies the run's clock jumps
# by seconds. The host boots the guest again (run-guest.sh), and the guest
# says why (the kernel's words on the TSC).
if [ "$(cat $source)" != tsc ]; then
  echo "daq-run: no tsc clock ($(cat $source); available: $(cat ${source%current_clocksource}available_clocksource))"
  dmesg | grep -i -E "tsc|clocksource" | tail -5
  reboot -f
fi
parameters=/sys/module/comedi_test/parameters
echo "daq-run: clock $(cat $source), amplitude $(cat $parameters/amplitude) uV period $(cat $parameters/period) us"
mkdir -p /tmp /runs
mount -t tmpfs none /runs
/check run --config /daq.toml --out /runs/daq --json \
  --set drive.rate_hz=2000 --set drive.comedi.preload_s=0.05 \
  --set sensor.comedi.span_start_V=-5 --set sensor.comedi.span_end_V=5 > /summary.json
status=$?
cat /summary.json
stty -F /dev/ttyS1 raw
{
  echo "summary"; base64 /summary.json
  echo "log"; base64 /runs/daq/run.h5
  echo "end"
} > /dev/ttyS1
echo "daq-run exit code: $status"
reboot -f
