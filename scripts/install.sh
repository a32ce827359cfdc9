#!/usr/bin/env bash
# Install the C library: scripts/install.sh [--keep-debug] PREFIX
#
#   PREFIX/include/phongrt.h                 (PHONGRT_VERSION_MAJOR/MINOR/PATCH and PHONGRT_VERSION
#                                             filled in from the workspace version)
#   PREFIX/lib/libphongrt.so.MAJOR.MINOR.PATCH, libphongrt.so.MAJOR (the SONAME) and libphongrt.so
#   PREFIX/lib/libphongrt.a
#   PREFIX/lib/pkgconfig/phongrt.pc
#   PREFIX/lib/cmake/phongrt/phongrtConfig.cmake (+ phongrtConfigVersion.cmake): phongrt::phongrt
#   PREFIX/share/doc/phongrt/                (the licences)
#   and, when the Embree 4 found is not a system package (not in the dynamic loader's search
#   path), its runtime and headers: PREFIX/lib/libembree4.so.4 (the file its SONAME names, and the
#   libembree4.so link), the TBB libraries libembree4 itself needs (its DT_NEEDED entries found
#   beside it), PREFIX/include/embree4/ (+ its copyright in PREFIX/share/doc/phongrt/).
#
# The libraries are installed stripped of debug information. With --keep-debug, the debug
# information of libphongrt.so goes to PREFIX/lib/debug/libphongrt.so.VERSION.debug, linked from the
# library by .gnu_debuglink (gdb finds it with `set debug-file-directory PREFIX/lib/debug`).
# The prefix's size is printed at the end.
#
# Embree is looked for in the order of build.rs: EMBREE_DIR, pkg-config `embree4`, /usr,
# /usr/local, /opt/homebrew, /opt/local, then the cache of scripts/setup-embree.sh.
#
# libphongrt.so is linked with the rpath $ORIGIN only (PHONGRT_INSTALL_RPATH=origin-only, read by
# crates/phongrt-capi/build.rs), so it finds a shipped Embree beside itself and otherwise the
# system's; the .pc and CMake files add an rpath to PREFIX/lib, so programs built against them run
# with no LD_LIBRARY_PATH. The build tree's libphongrt.so is relinked with its usual rpath at the end.
set -euo pipefail
cd "$(dirname "$0")/.."

die() { echo "install.sh: error: $*" >&2; exit 1; }
keep_debug=no
if [ "${1:-}" = --keep-debug ]; then
  keep_debug=yes
  shift
  # The release profile carries no debug information (Cargo.toml); this build does.
  export CARGO_PROFILE_RELEASE_DEBUG=1
fi
[ $# -eq 1 ] || die "usage: scripts/install.sh [--keep-debug] PREFIX"
prefix="$1"
case "$prefix" in /*) ;; *) prefix="$PWD/$prefix" ;; esac
case "$prefix" in *[[:space:]]*) die "PREFIX '$prefix' contains whitespace, which the flags of \`pkg-config phongrt\` cannot carry" ;; esac
[ "$(uname -s)" = Linux ] || die "only Linux is supported (the SONAME and \$ORIGIN rpath are ELF)"

# --- Find Embree 4, in build.rs's order ---------------------------------------------------------
# Prints the library directory of an Embree 4 install prefix (as build.rs's lib_dir_of).
lib_dir_of() {
  local d
  for d in lib lib64 lib/x86_64-linux-gnu lib/aarch64-linux-gnu; do
    if [ -e "$1/$d/libembree4.so" ]; then echo "$1/$d"; return 0; fi
  done
  return 1
}
emb_inc="" emb_lib="" emb_how=""
from_prefix() {
  [ -f "$1/include/embree4/rtcore.h" ] || return 1
  emb_inc="$1/include"
  emb_lib="$(lib_dir_of "$1")" || die "$2 $1 has include/embree4 but no lib*/libembree4.so"
  emb_how="$2 ($1)"
}
find_embree() {
  if [ -n "${EMBREE_DIR:-}" ]; then
    from_prefix "$EMBREE_DIR" EMBREE_DIR && return 0
    die "EMBREE_DIR=$EMBREE_DIR has no include/embree4/rtcore.h; point it at an Embree 4 install prefix"
  fi
  if command -v pkg-config >/dev/null && pkg-config --atleast-version=4.0 embree4 2>/dev/null; then
    local inc lib
    for inc in $(pkg-config --cflags-only-I embree4 | sed 's/-I//g') "$(pkg-config --variable=includedir embree4)"; do
      if [ -f "$inc/embree4/rtcore.h" ]; then
        lib="$(pkg-config --libs-only-L embree4 | sed 's/-L//g' | awk '{print $1}')"
        [ -n "$lib" ] || lib="$(pkg-config --variable=libdir embree4)"
        emb_inc="$inc" emb_lib="$lib" emb_how="pkg-config embree4 $(pkg-config --modversion embree4)"
        return 0
      fi
    done
  fi
  local p
  for p in /usr /usr/local /opt/homebrew /opt/local; do
    from_prefix "$p" system && return 0
  done
  local cache="${PHONGRT_CACHE:-${XDG_CACHE_HOME:+$XDG_CACHE_HOME/phongrt}}"
  cache="${cache:-$HOME/.cache/phongrt}"
  from_prefix "$cache/embree-4.4.0" "setup-embree.sh cache" && return 0
  return 1
}
if ! find_embree; then
  scripts/setup-embree.sh >/dev/null
  find_embree || die "Embree 4 was not found (EMBREE_DIR, pkg-config embree4, /usr, /usr/local, /opt/homebrew, /opt/local, the setup-embree.sh cache)"
fi
emb_lib="$(cd "$emb_lib" && pwd -P)"

# A system package: the dynamic loader finds its libembree4 with no rpath (ldconfig's cache or
# the default directories). Anything else is shipped beside libphongrt.
ship=yes
if { command -v ldconfig >/dev/null && ldconfig -p 2>/dev/null | grep -q " => $emb_lib/libembree4\.so"; } ||
   case "$emb_lib" in /lib|/lib64|/usr/lib|/usr/lib64|/usr/lib/*-linux-gnu|/lib/*-linux-gnu) true ;; *) false ;; esac; then
  ship=no
fi
echo "install.sh: Embree 4 from $emb_how: $emb_lib ($([ $ship = yes ] && echo "shipped into $prefix/lib" || echo "a system package, not copied"))" >&2

# --- Build ---------------------------------------------------------------------------------------
version="$(cargo pkgid -p phongrt-capi)"
version="${version##*[#@]}"
[[ "$version" =~ ^([0-9]+)\.([0-9]+)\.([0-9]+)$ ]] || die "cannot read a MAJOR.MINOR.PATCH version from cargo pkgid: $version"
major="${BASH_REMATCH[1]}" minor="${BASH_REMATCH[2]}" patch="${BASH_REMATCH[3]}"
target="${CARGO_TARGET_DIR:-target}/release"
PHONGRT_INSTALL_RPATH=origin-only cargo build --release --quiet -p phongrt-capi
# The build (build.rs, same search order) must have linked the Embree found here: its SONAME, as
# libphongrt.so records it, is in that directory.
needed="$(readelf -d "$target/libphongrt.so" | sed -n 's/.*NEEDED.*\[\(libembree4[^]]*\)\]/\1/p')"
[ -n "$needed" ] && [ -e "$emb_lib/$needed" ] || die "$target/libphongrt.so needs '$needed', which is not in $emb_lib: was it built against another Embree?"
readelf -d "$target/libphongrt.so" | grep -q "SONAME.*\[libphongrt\.so\.$major\]" || die "$target/libphongrt.so has no SONAME libphongrt.so.$major"
runpath="$(readelf -d "$target/libphongrt.so" | sed -n 's/.*R\(UN\)\{0,1\}PATH.*\[\(.*\)\]/\2/p')"
[ "$runpath" = '$ORIGIN' ] || die "$target/libphongrt.so has rpath '$runpath', expected \$ORIGIN alone"

# --- Install -------------------------------------------------------------------------------------
mkdir -p "$prefix/include" "$prefix/lib/pkgconfig" "$prefix/lib/cmake/phongrt" "$prefix/share/doc/phongrt"

# The header, with the version macros set to the workspace version (the tree's header carries the
# same values; crates/phongrt-capi/tests/c_install.rs checks that they agree with Cargo.toml).
sed -e "s/^#define PHONGRT_VERSION_MAJOR .*/#define PHONGRT_VERSION_MAJOR $major/" \
    -e "s/^#define PHONGRT_VERSION_MINOR .*/#define PHONGRT_VERSION_MINOR $minor/" \
    -e "s/^#define PHONGRT_VERSION_PATCH .*/#define PHONGRT_VERSION_PATCH $patch/" \
    -e "s/^#define PHONGRT_VERSION \".*\"/#define PHONGRT_VERSION \"$version\"/" \
    include/phongrt.h > "$prefix/include/phongrt.h.tmp"
grep -q "^#define PHONGRT_VERSION \"$version\"" "$prefix/include/phongrt.h.tmp" || die "include/phongrt.h has no PHONGRT_VERSION line"
mv "$prefix/include/phongrt.h.tmp" "$prefix/include/phongrt.h"

# The libraries: the real file, the SONAME link, the development link.
rm -f "$prefix/lib/libphongrt.so" "$prefix/lib/libphongrt.so.$major"
so="$prefix/lib/libphongrt.so.$version"
install -m 0755 "$target/libphongrt.so" "$so"
if [ "$keep_debug" = yes ]; then
  mkdir -p "$prefix/lib/debug"
  objcopy --only-keep-debug "$so" "$prefix/lib/debug/libphongrt.so.$version.debug"
  strip --strip-unneeded "$so"
  objcopy --add-gnu-debuglink="$prefix/lib/debug/libphongrt.so.$version.debug" "$so"
else
  strip --strip-unneeded "$so"
fi
ln -s "libphongrt.so.$version" "$prefix/lib/libphongrt.so.$major"
ln -s "libphongrt.so.$major" "$prefix/lib/libphongrt.so"
install -m 0644 "$target/libphongrt.a" "$prefix/lib/libphongrt.a"
strip --strip-debug "$prefix/lib/libphongrt.a"
install -m 0644 LICENSE-MIT LICENSE-APACHE "$prefix/share/doc/phongrt/"

# Embree: shipped beside libphongrt (symlinks kept), or referenced where the system has it.
if [ "$ship" = yes ]; then
  # Only what the loader needs: libembree4's SONAME (the file itself, under that name), the
  # development link, and the libraries libembree4 names as DT_NEEDED that sit beside it (TBB).
  emb_soname="$(readelf -d "$emb_lib/libembree4.so" | sed -n 's/.*SONAME.*\[\(.*\)\]/\1/p')"
  [ -n "$emb_soname" ] || die "$emb_lib/libembree4.so has no SONAME"
  rm -f "$prefix"/lib/libembree4*.so* "$prefix"/lib/libtbb*.so*
  ship_lib() { # ship_lib NAME: NAME's real file copied as NAME, stripped of debug information.
    install -m 0644 "$(readlink -f "$emb_lib/$1")" "$prefix/lib/$1"
    if readelf -S "$prefix/lib/$1" | grep -q '\.debug_info'; then strip --strip-debug "$prefix/lib/$1"; fi
  }
  ship_lib "$emb_soname"
  ln -s "$emb_soname" "$prefix/lib/libembree4.so"
  for dep in $(readelf -d "$emb_lib/$emb_soname" | sed -n 's/.*NEEDED.*\[\(.*\)\]/\1/p'); do
    if [ -e "$emb_lib/$dep" ]; then ship_lib "$dep"; fi
  done
  rm -rf "$prefix/include/embree4" && cp -r "$emb_inc/embree4" "$prefix/include/"
  cop="$(dirname "$emb_lib")/COPYRIGHT.embree"
  if [ -f "$cop" ]; then install -m 0644 "$cop" "$prefix/share/doc/phongrt/COPYRIGHT.embree"; fi
  pc_embree_cflags="" pc_embree_libs="-lembree4"
  cm_embree_inc="" cm_embree_lib="\${_phongrt_prefix}/lib/libembree4.so"
else
  case "$emb_inc" in /usr/include) pc_embree_cflags="" cm_embree_inc="" ;;
                     *) pc_embree_cflags=" -I$emb_inc" cm_embree_inc=";$emb_inc" ;; esac
  pc_embree_libs="-L$emb_lib -lembree4"
  cm_embree_lib="$emb_lib/libembree4.so"
fi

# Libs.private: what the Rust staticlib needs from the system (rustc --print native-static-libs).
cat > "$prefix/lib/pkgconfig/phongrt.pc" <<PC
prefix=$prefix
libdir=\${prefix}/lib
includedir=\${prefix}/include

Name: phongrt
Description: Phong Tessellation ray traced directly as an Embree 4 user geometry
Version: $version
Cflags: -I\${includedir}$pc_embree_cflags
Libs: -L\${libdir} -Wl,-rpath,\${libdir} -lphongrt $pc_embree_libs
Libs.private: -lgcc_s -lutil -lrt -lpthread -lm -ldl -lc
PC

cat > "$prefix/lib/cmake/phongrt/phongrtConfig.cmake" <<CM
# phongrt $version: find_package(phongrt) defines the imported target phongrt::phongrt (the shared
# library, its header and Embree 4). Programs linked with it get an rpath to this prefix's lib.
get_filename_component(_phongrt_prefix "\${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
if(NOT TARGET phongrt::phongrt)
  add_library(phongrt::phongrt SHARED IMPORTED)
  set_target_properties(phongrt::phongrt PROPERTIES
    IMPORTED_LOCATION "\${_phongrt_prefix}/lib/libphongrt.so.$major"
    IMPORTED_SONAME "libphongrt.so.$major"
    INTERFACE_INCLUDE_DIRECTORIES "\${_phongrt_prefix}/include$cm_embree_inc"
    INTERFACE_LINK_LIBRARIES "$cm_embree_lib"
    INTERFACE_LINK_OPTIONS "-Wl,-rpath,\${_phongrt_prefix}/lib")
endif()
set(phongrt_INCLUDE_DIRS "\${_phongrt_prefix}/include$cm_embree_inc")
set(phongrt_LIBRARIES phongrt::phongrt)
set(phongrt_VERSION "$version")
unset(_phongrt_prefix)
CM

cat > "$prefix/lib/cmake/phongrt/phongrtConfigVersion.cmake" <<CV
# Same major version and at least the version asked for (0.x: same minor too, as Cargo's rule).
set(PACKAGE_VERSION "$version")
if(PACKAGE_FIND_VERSION VERSION_GREATER PACKAGE_VERSION
   OR NOT PACKAGE_FIND_VERSION_MAJOR EQUAL $major
   OR ($major EQUAL 0 AND NOT PACKAGE_FIND_VERSION_MINOR EQUAL $minor))
  set(PACKAGE_VERSION_COMPATIBLE FALSE)
else()
  set(PACKAGE_VERSION_COMPATIBLE TRUE)
  if(PACKAGE_FIND_VERSION VERSION_EQUAL PACKAGE_VERSION)
    set(PACKAGE_VERSION_EXACT TRUE)
  endif()
endif()
CV

# Put the build tree's libphongrt.so back (its rpath also names the Embree it was built with).
cargo build --release --quiet -p phongrt-capi

echo "installed phongrt $version into $prefix ($(du -sh "$prefix" | cut -f1) in all)"
