#!/usr/bin/env bash
# Fetches (through apt, never the web) Debian's stock 6.1 kernel for the SocketCAN VM test and unpacks it
# into a cache OUTSIDE the repository. Idempotent: a second run with the cache present only prints paths.
# Output layout:  $IMUFORGE_VM_CACHE/current -> <version>/{boot/vmlinuz-*, lib/modules/<version>/...}
set -euo pipefail
cache="${IMUFORGE_VM_CACHE:-/var/cache/imuforge-vm}"
mkdir -p "$cache"

if [ -L "$cache/current" ] && ls "$cache"/current/boot/vmlinuz-* >/dev/null 2>&1; then
  echo "fetch-kernel: cached $(readlink "$cache/current")"
  exit 0
fi

# The newest plain amd64 6.1 kernel image apt knows (names like linux-image-6.1.0-50-amd64).
pkg=$(apt-cache search --names-only '^linux-image-6\.1\.0-[0-9]+-amd64(-unsigned)?$' \
        | awk '{print $1}' | sort -V | tail -1)
if [ -z "$pkg" ]; then
  apt-get update -qq || true
  pkg=$(apt-cache search --names-only '^linux-image-6\.1\.0-[0-9]+-amd64(-unsigned)?$' \
          | awk '{print $1}' | sort -V | tail -1)
fi
if [ -z "$pkg" ]; then
  echo "fetch-kernel: no linux-image-6.1.0-*-amd64 package known to apt" >&2
  exit 1
fi
ver=${pkg#linux-image-}; ver=${ver%-unsigned}
dl="$cache/deb"
mkdir -p "$dl"
if ! ls "$dl"/"$pkg"_*.deb >/dev/null 2>&1; then
  (cd "$dl" && apt-get download "$pkg")
fi
deb=$(ls "$dl"/"$pkg"_*.deb | head -1)
tmp="$cache/$ver.tmp"
rm -rf "$tmp"
mkdir -p "$tmp"
dpkg -x "$deb" "$tmp"
rm -rf "${cache:?}/$ver"
mv "$tmp" "$cache/$ver"
ln -sfn "$ver" "$cache/current"
echo "fetch-kernel: unpacked $pkg into $cache/$ver"
