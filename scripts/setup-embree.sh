#!/usr/bin/env bash
# Provide Embree 4 (headers + runtime) and libclang for bindgen, on machines whose OS has no Embree 4
# (Debian 12, Ubuntu 22.04). Idempotent; the only system change is `apt-get install libclang-dev`.
#
# Where a system Embree 4 exists (EMBREE_DIR, pkg-config `embree4`, /usr/include/embree4), nothing is
# fetched. Otherwise it assembles, in a cache outside the clone
# (${PHONGRT_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/phongrt}/embree-4.4.0):
#   include/embree4/  the Embree 4.3.3 headers from Debian 13's libembree-dev .deb
#   lib/              the Embree 4.4.0 runtime (+ its TBB) from PyPI's embreex==4.4.0.post1 manylinux wheel
# Both downloads are checked against pinned SHA-256 sums. build.rs looks in this cache by itself, so
# after this script a plain `cargo build` works. Prints the Embree directory on its last line.
set -euo pipefail

log() { echo "setup-embree: $*" >&2; }
die() { echo "setup-embree: error: $*" >&2; exit 1; }

cache_root="${PHONGRT_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/phongrt}"
dest="$cache_root/embree-4.4.0"

deb_name="libembree-dev_4.3.3+dfsg-1_amd64.deb"
deb_sha="674a8b3d1a00612f46730da29f4cc146267b4917bbf0242113d0568429e78726"
whl_spec="embreex==4.4.0.post1"
whl_sha="2cd0f7d5c6342e6247e31f700761689cae7829454d8c6de0c41e62124a023e1f"

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

# 1. libclang for bindgen (and a C compiler for the C API test).
have_libclang() {
  [ -n "${LIBCLANG_PATH:-}" ] && return 0
  # libclang itself (libclang-cpp, present on a fresh Debian 12, is not what bindgen loads).
  local f
  for f in /usr/lib/llvm-*/lib/libclang.so* /usr/lib/llvm-*/lib/libclang-[0-9]*.so* \
           /usr/lib/*-linux-gnu/libclang.so* /usr/lib/*-linux-gnu/libclang-[0-9]*.so*; do
    [ -e "$f" ] && return 0
  done
  return 1
}
if ! have_libclang; then
  command -v apt-get >/dev/null || die "libclang not found and no apt-get: install libclang (for bindgen) and set LIBCLANG_PATH"
  log "installing libclang-dev (for bindgen) with apt-get"
  as_root apt-get update -qq >&2
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq libclang-dev >&2
fi

# 2. A system Embree 4 wins.
if [ -n "${EMBREE_DIR:-}" ]; then
  [ -f "$EMBREE_DIR/include/embree4/rtcore.h" ] || die "EMBREE_DIR=$EMBREE_DIR has no include/embree4/rtcore.h"
  echo "$EMBREE_DIR"; exit 0
fi
if pkg-config --exists embree4 2>/dev/null || [ -f /usr/include/embree4/rtcore.h ] || [ -f /usr/local/include/embree4/rtcore.h ]; then
  log "using the system Embree 4"
  echo "system"; exit 0
fi

# 3. Already assembled?
if [ -f "$dest/.complete" ]; then
  echo "$dest"; exit 0
fi

[ "$(uname -m)" = x86_64 ] || die "no Embree 4 found and the fetched one is x86_64 only: install Embree 4 and set EMBREE_DIR"
command -v python3 >/dev/null || die "python3 is needed to fetch the Embree runtime wheel"

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
log "assembling Embree 4 in $dest"

# 3a. Headers: Debian 13 (trixie) libembree-dev, fetched with a private sources list and lists dir.
mkdir -p "$work/apt/lists/partial" "$work/apt/cache/archives/partial" "$work/apt/parts"
keyring=/usr/share/keyrings/debian-archive-trixie-stable.gpg
[ -f "$keyring" ] || keyring=/usr/share/keyrings/debian-archive-keyring.gpg
echo "deb [signed-by=$keyring] http://deb.debian.org/debian trixie main" >"$work/apt/sources.list"
apt_opts=(-o "Dir::Etc::SourceList=$work/apt/sources.list" -o "Dir::Etc::SourceParts=$work/apt/parts"
          -o "Dir::State::Lists=$work/apt/lists" -o "Dir::Cache=$work/apt/cache" -o "APT::Sandbox::User=root"
          -o "Acquire::Languages=none" -o "Acquire::IndexTargets::deb::DEP-11::DefaultEnabled=false")
apt-get "${apt_opts[@]}" -qq update >&2 || die "apt-get update of the private trixie list failed"
(cd "$work" && apt-get "${apt_opts[@]}" -qq download libembree-dev=4.3.3+dfsg-1 >&2) \
  || die "could not download $deb_name"
echo "$deb_sha  $work/$deb_name" | sha256sum -c --quiet - || die "checksum mismatch for $deb_name"
dpkg -x "$work/$deb_name" "$work/deb"

# 3b. Runtime: the embreex manylinux wheel (Embree 4.4.0 + TBB, sonames mangled by auditwheel).
python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.11 --implementation cp \
  --abi cp311 --platform manylinux_2_28_x86_64 -d "$work/whl" "$whl_spec" >&2 || die "could not download $whl_spec"
whl="$(ls "$work"/whl/*.whl)"
echo "$whl_sha  $whl" | sha256sum -c --quiet - || die "checksum mismatch for $whl"
python3 -m zipfile -e "$whl" "$work/whl/x"

# 3c. Assemble: unmangled names as symlinks to the mangled ones (their SONAMEs, recorded by the
# linker, are the mangled names, which sit beside them; the embree lib finds TBB through $ORIGIN).
rm -rf "$dest.tmp" && mkdir -p "$dest.tmp/include" "$dest.tmp/lib"
cp -r "$work/deb/usr/include/embree4" "$dest.tmp/include/"
cp "$work"/whl/x/embreex.libs/*.so* "$dest.tmp/lib/"
emb="$(cd "$dest.tmp/lib" && ls libembree4-*.so.4)"
ln -s "$emb" "$dest.tmp/lib/libembree4.so.4"
ln -s "$emb" "$dest.tmp/lib/libembree4.so"
cp "$work/deb/usr/share/doc/libembree-dev/copyright" "$dest.tmp/COPYRIGHT.embree"
touch "$dest.tmp/.complete"
rm -rf "$dest" && mkdir -p "$cache_root" && mv "$dest.tmp" "$dest"
log "done"
echo "$dest"
