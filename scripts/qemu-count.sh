# Sourced by the aarch64 counting scripts: sets up the cross build and qemu's counting
# plugin (scripts/qemu/insn_count.c, built once), and defines
#   qemu_count BIN ARGS...   every guest instruction BIN executes, printed as one number.
target=aarch64-unknown-linux-gnu
bash scripts/cross-setup.sh >/dev/null
plugin=target/qemu-plugins/insn_count.so
mkdir -p "$(dirname "$plugin")"
if [ ! -f "$plugin" ] || [ scripts/qemu/insn_count.c -nt "$plugin" ]; then
  gcc -O2 -shared -fPIC -fvisibility=hidden -o "$plugin" scripts/qemu/insn_count.c
fi
qemu_count() {
  qemu-aarch64 -L /usr/aarch64-linux-gnu -plugin "$plugin" -d plugin "$@" 2>&1 \
    | sed -n 's/^guest instructions: \([0-9]*\)$/\1/p'
}
