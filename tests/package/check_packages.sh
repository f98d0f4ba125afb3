#!/usr/bin/env bash
# tests/package/check_packages.sh BUILD_DIR SOURCE_DIR [ARCH [EMULATOR]] (ctest label
# `package`: the `package` preset for amd64, `package-arm64` for arm64): makes the Debian packages with cpack, then checks them as an operator
# would meet them, without touching this machine's system: the file lists and control
# data, and, unpacked into a scratch root (dpkg-deb -x), the systemd unit parses
# (systemd-analyze verify --root) and the installed binary checks the installed config
# (through EMULATOR, qemu-aarch64-static, for a foreign ARCH). The simulation package
# is checked where the build makes it (not arm64: no arm64 Bullet).
set -euo pipefail
build=$1
source=$2
fail() { echo "check_packages: FAIL: $*" >&2; exit 1; }
cd "$build"
rm -rf packages
cpack --config CPackConfig.cmake -B packages >cpack.log 2>&1 || { cat cpack.log; fail "cpack"; }
arch=${3:-$(dpkg --print-architecture)}
emulator=()
[[ -n ${4:-} ]] && emulator=("$4")
version=$(sed -n 's/^project(springbok VERSION \([0-9.]*\).*/\1/p' "$source/CMakeLists.txt")
fw=packages/springbok_${version}_${arch}.deb
sim=packages/springbok-sim_${version}_${arch}.deb
[[ -f $fw ]] || fail "no $fw (made: $(ls packages))"
have_sim=0
[[ -f $sim ]] && have_sim=1
[[ $have_sim == 1 || $arch != "$(dpkg --print-architecture)" ]] || fail "no $sim (made: $(ls packages))"

# File lists: what each package must hold.
list=$(dpkg-deb -c "$fw" | awk '{print $6}')
for f in ./usr/bin/springbok ./usr/bin/springbok-can-up ./usr/bin/springbokctl ./usr/bin/springbok-teleop ./etc/springbok/springbok.yaml ./usr/lib/systemd/system/springbok.service; do
  grep -qx "$f" <<<"$list" || fail "$fw lacks $f"
done
grep -q 'springbok-sim\|springbok-on-sim' <<<"$list" && fail "$fw holds a simulation binary"
simlist=""
[[ $have_sim == 1 ]] && simlist=$(dpkg-deb -c "$sim" | awk '{print $6}')
[[ $have_sim == 1 ]] && for f in ./usr/bin/springbok-on-sim ./usr/bin/springbok-sim ./usr/bin/drive_emulator ./usr/bin/springbok-dyn \
         ./usr/bin/springbok-qp ./usr/bin/urdf2model ./usr/bin/springbok-view ./usr/share/springbok/scenarios/base_step_mb92.yaml; do
  grep -qx "$f" <<<"$simlist" || fail "$sim lacks $f"
done

# Control data: architecture, the conffile, the postinst that makes the user.
[[ $(dpkg-deb -f "$fw" Architecture) == "$arch" ]] || fail "$fw: Architecture $(dpkg-deb -f "$fw" Architecture)"
[[ $have_sim == 0 || $(dpkg-deb -f "$sim" Depends) == *"springbok (= $version)"* ]] || fail "$sim does not depend on springbok $version"
control=$(mktemp -d)
trap 'rm -rf "$control" "${root:-}"' EXIT
dpkg-deb -e "$fw" "$control"
grep -qx /etc/springbok/springbok.yaml "$control/conffiles" || fail "the config is not a conffile"
grep -q 'useradd --system' "$control/postinst" || fail "postinst makes no springbok user"
sh -n "$control/postinst" || fail "postinst does not parse"

# Unpacked into a scratch root.
root=$(mktemp -d)
dpkg-deb -x "$fw" "$root"
[[ $have_sim == 1 ]] && dpkg-deb -x "$sim" "$root"
unit=$root/usr/lib/systemd/system/springbok.service
grep -q '^ExecStart=/usr/bin/springbok --config /etc/springbok/springbok.yaml' "$unit" || fail "unit ExecStart: $(grep ExecStart= "$unit")"
grep -q '^ExecStartPre=+/usr/bin/springbok-can-up --config /etc/springbok/springbok.yaml' "$unit" ||
  fail "unit ExecStartPre: $(grep ExecStartPre= "$unit")"
for key in LimitRTPRIO LimitMEMLOCK User=springbok; do grep -q "^$key" "$unit" || fail "unit lacks $key"; done
# systemd-analyze verify checks that ExecStart's binary exists: a copy of the unit
# whose paths point into the scratch root is verified against this machine's units.
if command -v systemd-analyze >/dev/null; then
  scratch_unit=$root/springbok.service
  sed "s#=\(+\?\)/usr/bin/#=\1$root/usr/bin/#; s#--config /etc/#--config $root/etc/#" "$unit" >"$scratch_unit"
  out=$(systemd-analyze verify "$scratch_unit" 2>&1) || fail "systemd-analyze verify: $out"
  [[ -z $out ]] || fail "systemd-analyze verify warns: $out"
  echo "check_packages: systemd-analyze verify: ok"
else
  echo "check_packages: systemd-analyze not installed: unit parse check skipped"
fi
out=$("${emulator[@]}" "$root/usr/bin/springbok" --check-config --config "$root/etc/springbok/springbok.yaml" 2>&1) ||
  fail "installed springbok --check-config on the installed config: $out"
grep -q 'config OK' <<<"$out" || fail "--check-config said: $out"
out=$("${emulator[@]}" "$root/usr/bin/springbok-can-up" --dry-run --config "$root/etc/springbok/springbok.yaml" 2>&1) ||
  fail "installed springbok-can-up --dry-run: $out"
[[ $(grep -c ' up$' <<<"$out") == 8 ]] || fail "springbok-can-up brings up $(grep -c ' up$' <<<"$out") interfaces, not 8: $out"
[[ $(dpkg-deb -f "$fw" Depends) == *libevdev2* ]] || fail "$fw does not depend on libevdev2 (springbok-teleop): $(dpkg-deb -f "$fw" Depends)"
"${emulator[@]}" "$root/usr/bin/springbok-teleop" --help >/dev/null || fail "installed springbok-teleop --help"
ver=$("${emulator[@]}" "$root/usr/bin/springbok" --version)
[[ $(head -n 1 <<<"$ver") == "springbok $version (revision "*")" ]] || fail "--version said: $ver"
# The kernels it runs: the amd64 package holds every x86-64 level's and picks one the CPU runs.
kernels=$(sed -n 2p <<<"$ver")
case $arch in
  amd64) [[ $kernels == "kernels x86-64"*" (compiled: x86-64 x86-64-v3 x86-64-v4; CPU: x86-64"*")" ]] ;;
  arm64) [[ $kernels == "kernels armv8-a (compiled: armv8-a; CPU: armv8-a)" ]] ;;
  *) true ;;
esac || fail "--version's kernels on $arch: $kernels"
ver=$(head -n 1 <<<"$ver")
[[ $have_sim == 0 ]] || "$root/usr/bin/springbok-sim" --help >/dev/null || fail "springbok-sim --help"
[[ $have_sim == 0 ]] || "$root/usr/bin/springbok-view" --help >/dev/null || fail "springbok-view --help"
echo "check_packages: $fw ($(wc -l <<<"$list") entries)$([[ $have_sim == 1 ]] && echo ", $sim ($(wc -l <<<"$simlist") entries)"): ok; $ver"
