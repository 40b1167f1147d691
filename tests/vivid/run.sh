#!/usr/bin/env bash
# Boots a minimal Linux VM with the kernel's `vivid` virtual camera and runs our capture
# check (tests/src/bin/vivid-capture.rs) against it: the real V4L2 code path — buffer
# negotiation, mmap streaming, format and size negotiation, newest-frame policy, recovery
# when the driver is unbound and rebound — with nothing but Debian packages.
#
#   bash tests/vivid/run.sh          # prints the checks; exit status 0 when all pass
#
# Needs: qemu-system-x86, busybox-static, kmod, cpio (installed when missing), and a Debian
# kernel image package (downloaded once into target/vivid/). Software emulation (TCG):
# about 15 s for the VM on 2 cores, plus the first build.
set -euo pipefail
cd "$(dirname "$0")/../.."
work=target/vivid
mkdir -p "$work"

need=()
for p in qemu-system-x86 busybox-static kmod cpio; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || need+=("$p")
done
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO=sudo
  $SUDO apt-get update -q || true
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${need[@]}"
fi

# The newest stock amd64 kernel the archive offers (it ships vivid.ko).
deb=$(ls "$work"/linux-image-*-amd64_*.deb 2>/dev/null | sort -V | tail -1 || true)
if [ -z "$deb" ]; then
  pkg=$(apt-cache search --names-only '^linux-image-[0-9.]+-[0-9]+-amd64$' | awk '{print $1}' | sort -V | tail -1)
  [ -n "$pkg" ] || { echo "vivid: no Debian kernel image package found (apt-cache search)" >&2; exit 1; }
  (cd "$work" && apt-get download "$pkg")
  deb=$(ls "$work"/linux-image-*-amd64_*.deb | sort -V | tail -1)
fi
root="$work/kernel"
if [ ! -d "$root/boot" ]; then
  rm -rf "$root"; dpkg -x "$deb" "$root"
fi
kver=$(ls "$root/lib/modules" | head -1)
vmlinuz="$root/boot/vmlinuz-$kver"

# The capture check, static so it is the VM's only program.
target=x86_64-unknown-linux-gnu
RUSTFLAGS="-C target-feature=+crt-static" cargo build --release -q --target "$target" \
  -p vistaf-tests --bin vivid-capture --features v4l-test
bin=target/$target/release/vivid-capture

# initramfs: busybox, the media modules in dependency order, the check, /init.
init="$work/initramfs"
rm -rf "$init"; mkdir -p "$init"/{bin,dev,proc,sys,mod}
cp /bin/busybox "$init/bin/busybox"
for a in sh mount insmod poweroff sleep cat echo ls; do ln -s busybox "$init/bin/$a"; done
cp "$bin" "$init/vivid-capture"
mods=(rc-core cec mc videodev videobuf2-common videobuf2-v4l2 videobuf2-memops
      videobuf2-vmalloc videobuf2-dma-contig v4l2-dv-timings v4l2-tpg vivid)
order=""
for m in "${mods[@]}"; do
  f=$(find "$root/lib/modules/$kver" -name "$m.ko*" | head -1)
  [ -n "$f" ] || { echo "vivid: module $m not in $deb" >&2; exit 1; }
  case "$f" in
    *.xz) xz -dc "$f" > "$init/mod/$m.ko" ;;
    *.zst) zstd -dqc "$f" > "$init/mod/$m.ko" ;;
    *) cp "$f" "$init/mod/$m.ko" ;;
  esac
  order="$order $m"
done
cat > "$init/init" <<INIT
#!/bin/sh
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
for m in $order; do insmod /mod/\$m.ko || echo "VIVID-CHECK insmod-\$m: FAIL"; done
sleep 1
/vivid-capture
poweroff -f
INIT
chmod +x "$init/init"
(cd "$init" && find . | cpio -o -H newc --quiet | gzip -1) > "$work/initrd.gz"

log="$work/console.log"
timeout 300 qemu-system-x86_64 -accel tcg -m 512 -smp 1 -nographic -no-reboot \
  -kernel "$vmlinuz" -initrd "$work/initrd.gz" \
  -append "console=ttyS0 panic=-1 loglevel=3 edd=off" | tee "$log" | grep --line-buffered "VIVID-" || true
grep -q "VIVID-RESULT PASS" "$log"
