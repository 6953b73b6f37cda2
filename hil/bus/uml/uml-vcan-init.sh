# Body of the UML guest's init, appended by uml-vcan.sh after the lines
# that set: exported pass-through variables, work (host temp dir, visible
# through hostfs), cwd, start_ns (host clock at launch), cmd (array).
# Runs as pid 1: it must end with halt, never exit.

finish() {  # finish STATUS: hand STATUS to the host, then power off
    echo "$1" >"$work/status.tmp" && mv "$work/status.tmp" "$work/status"
    sync
    halt -f -d
}

setup() {
    mount -t proc proc /proc
    mount -t sysfs sys /sys
    # UML mounts its own devtmpfs on /dev: no shm or pts in it.
    mkdir -p /dev/shm /dev/pts
    mount -t tmpfs -o mode=1777 tmpfs /dev/shm
    mount -t devpts devpts /dev/pts
    ip link set lo up
    local mods=/usr/lib/uml/modules/$(uname -r)/kernel m ch
    for m in net/can/can.ko net/can/can-raw.ko drivers/net/can/dev/can-dev.ko \
             drivers/net/can/vcan.ko; do
        insmod "$mods/$m" || return 1
    done
    for ch in vcan0 vcan1; do
        ip link add dev "$ch" type vcan || return 1
        ip link set "$ch" txqueuelen 1000 up || return 1
    done
}

# The console is a tty: keep "\n" as is so the host sees plain lines.
stty -onlcr 2>/dev/null
if ! setup 2>"$work/setup.err"; then
    echo "uml-vcan: guest setup failed:"
    cat "$work/setup.err"
    finish 125
fi
boot_ns=$(date +%s%N)
printf 'uml-vcan: booted with vcan0/vcan1 in %.1f s\n' "$(( (boot_ns - start_ns) / 1000000 ))e-3"

export PYTHONUNBUFFERED=1
cd "$cwd" || finish 125
# Through a pipe, CMD's stdout is no tty: no colour codes in CI logs.
"${cmd[@]}" </dev/null 2>&1 | cat
status=${PIPESTATUS[0]}
end_ns=$(date +%s%N)
printf 'uml-vcan: command exited %d after %.1f s inside UML\n' "$status" "$(( (end_ns - boot_ns) / 1000000 ))e-3"
finish "$status"
