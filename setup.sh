#!/usr/bin/env bash
# Installs every Debian package that any imuforge build, test, benchmark or demo needs.
# Idempotent: packages already present are skipped by apt-get; `apt-get update` runs once per call.
# Also fetches (through apt, never the web) the Debian kernel image the SocketCAN VM test boots.
set -euo pipefail

if [ "$(id -u)" -ne 0 ]; then
  echo "setup.sh: run as root (it installs Debian packages with apt-get)" >&2
  exit 1
fi

PACKAGES=(
  # host toolchain and build
  build-essential cmake ninja-build pkg-config git
  # numerics, I/O, CLI
  libeigen3-dev nlohmann-json3-dev libcli11-dev libsqlite3-dev sqlite3
  # fixture: Modbus, and the real clients/peers the tests start
  libmodbus-dev mbpoll socat
  # CAN: can-utils (candump) inside the VM; the VM itself and its initramfs
  can-utils qemu-system-x86 busybox-static cpio kmod xz-utils zstd
  # cross toolchain and Cortex-M emulation
  gcc-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-newlib qemu-system-arm
  # tests, fuzzing, benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev clang-14 libclang-rt-14-dev lld
  # records: PostgreSQL server and client library for the multi-station test
  postgresql libpq-dev
  # python3 for small test helpers; numpy for the independent blind-log generator (tools/blindgen)
  python3 python3-numpy
)

export DEBIAN_FRONTEND=noninteractive
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
apt-get update -qq
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup.sh: installing ${missing[*]}"
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "setup.sh: all ${#PACKAGES[@]} packages present"
fi

# The SocketCAN VM boots Debian's own kernel (this host kernel has no CAN support).
here="$(cd "$(dirname "$0")" && pwd)"
if [ -x "$here/tests/vm/fetch-kernel.sh" ]; then
  "$here/tests/vm/fetch-kernel.sh"
fi
