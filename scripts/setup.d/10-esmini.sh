#!/usr/bin/env bash
# The esmini player (player/, `scenweave doctor`), idempotent. Setup uses the first of:
#  1. $ESMINI_HOME, when it holds a loadable bin/libesminiLib.so (keep it set at run time);
#  2. the workplace copy ../shared/esmini beside this repository (absent in users' clones);
#  3. $ESMINI_SOURCE_ARCHIVE, an esmini source .tar.xz/.tar.gz, built headless with the recipe
#     of ../shared/esmini/build_esmini.sh (no viewer, OSI, SUMO, tests; about 6 min on two
#     cores; cmake, g++ and make are installed with apt-get when missing) and installed into
#     /opt/scenweave/esmini; the build is cached by the archive's sha256 in
#     ~/.cache/scenweave/esmini (SCENWEAVE_ESMINI_CACHE), so a second setup does not rebuild;
#  4. an earlier install in /opt/scenweave/esmini (SCENWEAVE_ESMINI_PREFIX moves it);
#  5. esmini's official Linux release archive (ESMINI_RELEASE_URL), where it can be reached.
# It prints one line saying which it used; when none works, one line saying what was tried,
# and it does not fail: replay is then unavailable. player/locate.py searches in this order.
set -euo pipefail
cd "$(dirname "$0")/../.."

PREFIX=${SCENWEAVE_ESMINI_PREFIX:-/opt/scenweave/esmini}
CACHE=${SCENWEAVE_ESMINI_CACHE:-$HOME/.cache/scenweave/esmini}
RELEASE_URL=${ESMINI_RELEASE_URL:-https://github.com/esmini/esmini/releases/download/v3.6.0/esmini-bin_Linux.zip}
WORKPLACE=../shared/esmini
STAMP=.scenweave-esmini            # in $PREFIX: what the install was made from
PY=.venv/bin/python
[ -x "$PY" ] || PY=python3

tried=()   # every place looked at, for the line saying nothing worked
notes=()   # explicit settings that did not work, appended to the line saying what was used

# usable HOME: sets $version when HOME/bin/libesminiLib.so loads, else $problem
usable() {
    local lib=$1/bin/libesminiLib.so out
    version='' problem=''
    if [ ! -f "$lib" ]; then
        problem="no $lib"
        return 1
    fi
    # esmini_build_version() is a C++ function (mangled name), see player/locate.py
    if ! out=$("$PY" -c 'import ctypes, sys
f = getattr(ctypes.CDLL(sys.argv[1]), "_Z20esmini_build_versionv")
f.restype = ctypes.c_char_p
print((f() or b"unknown").decode(errors="replace"))' "$lib" 2>&1); then
        problem="$lib does not load ($(tail -n 1 <<<"$out"))"
        return 1
    fi
    version=$out
}

used() {
    local line="esmini: using $*"
    [ "${#notes[@]}" -eq 0 ] || line+=" [$(joined "${notes[@]}")]"
    echo "$line"
    exit 0
}

joined() { local out; out=$(printf '%s; ' "$@"); echo "${out%; }"; }

stamp_of() { head -n 1 "$1/$STAMP" 2>/dev/null || true; }

# checked COMMAND...: its exit status, with `set -e` in force inside it (bash ignores -e in
# functions and subshells run as an `if` condition or in an `||` list)
checked() { set +e; "$@"; status=$?; set -e; return 0; }

# install_into_prefix FOLDER STAMP: copy FOLDER's bin/ and include/ into $PREFIX atomically
install_into_prefix() (
    set -euo pipefail
    new=$PREFIX.new.$$ old=$PREFIX.old.$$
    mkdir -p "$(dirname "$PREFIX")"
    rm -rf "$new"
    mkdir "$new"
    cp -R "$1/bin" "$new/"
    [ ! -d "$1/include" ] || cp -R "$1/include" "$new/"
    echo "$2" > "$new/$STAMP"
    chmod -R a+rX "$new"
    [ ! -e "$PREFIX" ] || mv "$PREFIX" "$old"
    mv "$new" "$PREFIX"
    rm -rf "$old"
)

# need_tools COMMAND...: install the Debian packages for missing build tools (root only)
need_tools() {
    local missing=() tool
    for tool in "$@"; do
        command -v "$tool" >/dev/null || missing+=("$tool")
    done
    [ "${#missing[@]}" -eq 0 ] && return 0
    if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null; then
        echo "needs ${missing[*]} (install cmake, g++, make, xz-utils)" >&2
        return 1
    fi
    local packages=()
    for tool in "${missing[@]}"; do
        case $tool in c++) packages+=(g++) ;; xz) packages+=(xz-utils) ;; *) packages+=("$tool") ;; esac
    done
    echo "esmini: installing Debian packages for the build: ${packages[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        "${packages[@]}" >/dev/null
}

# build_source ARCHIVE DEST LOG: the headless recipe of build_esmini.sh; DEST gets bin/, include/
build_source() (
    set -euo pipefail
    work=$(mktemp -d "${TMPDIR:-/var/tmp}/scenweave-esmini.XXXXXX")
    trap 'rm -rf "$work"' EXIT
    case $1 in *.xz) need_tools xz ;; esac
    tar -xf "$1" -C "$work"
    top=$(find "$work" -maxdepth 2 -name CMakeLists.txt -print | sort | head -n 1)
    [ -n "$top" ] || { echo "no CMakeLists.txt in $1" >&2; exit 1; }
    src=$(dirname "$top")
    need_tools cmake c++ make
    # the archive's own version file (v3.6.0-131a5651); without git esmini would say N/A
    version_flag=()
    [ ! -s "$src/.esmini_version" ] || version_flag=(-DESMINI_BUILD_VERSION="$(head -n 1 "$src/.esmini_version")")
    {
        nice cmake -S "$src" -B "$work/build" -DCMAKE_BUILD_TYPE=Release -DDOWNLOAD_EXTERNALS=OFF \
            -DUSE_OSG=OFF -DUSE_OSI=OFF -DUSE_SUMO=OFF -DUSE_GTEST=OFF -DUSE_IMPLOT=OFF \
            -DBUILD_ODRPLOT=OFF -DBUILD_REPLAYER=OFF -DBUILD_EXAMPLES=OFF -DENABLE_CCACHE=OFF \
            "${version_flag[@]}"
        nice cmake --build "$work/build" -j "${JOBS:-$(nproc)}"
        cmake --install "$work/build"                     # into $src/bin
    } >"$3" 2>&1
    out=$work/out
    mkdir -p "$out/bin" "$out/include"
    for file in libesminiLib.so libesminiRMLib.so esmini dat2csv; do
        [ ! -e "$src/bin/$file" ] || cp "$src/bin/$file" "$out/bin/"
    done
    find "$src/EnvironmentSimulator/Libraries" \( -name esminiLib.hpp -o -name esminiRMLib.hpp \) \
        -exec cp {} "$out/include/" \;
    rm -rf "$2"
    mkdir -p "$(dirname "$2")"
    mv "$out" "$2"
)

# fetch_release URL DEST: download (short timeouts) and unpack the release's bin/ and headers
fetch_release() (
    set -euo pipefail
    work=$(mktemp -d "${TMPDIR:-/var/tmp}/scenweave-esmini-release.XXXXXX")
    trap 'rm -rf "$work"' EXIT
    # a quick look first: an unreachable host (no DNS, no route) fails here within seconds
    timeout 15 "$PY" - "$1" <<'EOF' || exit 1
import sys, urllib.request
try:
    urllib.request.urlopen(urllib.request.Request(sys.argv[1], method="HEAD"), timeout=5).close()
except Exception as err:
    sys.exit(f"unreachable ({type(err).__name__}: {err})")
EOF
    "$PY" - "$1" "$work/release.zip" "$work/unpacked" <<'EOF'
import shutil, sys, urllib.request, zipfile
url, archive, folder = sys.argv[1:]
try:
    with urllib.request.urlopen(url, timeout=20) as answer, open(archive, "wb") as out:
        shutil.copyfileobj(answer, out)
    zipfile.ZipFile(archive).extractall(folder)
except Exception as err:
    sys.exit(f"download failed ({type(err).__name__}: {err})")
EOF
    lib=$(find "$work/unpacked" -name libesminiLib.so -path '*/bin/*' | sort | head -n 1)
    [ -n "$lib" ] || { echo "no bin/libesminiLib.so in the archive" >&2; exit 1; }
    out=$work/out
    mkdir -p "$out/bin" "$out/include"
    for file in libesminiLib.so libesminiRMLib.so esmini dat2csv; do
        [ ! -e "$(dirname "$lib")/$file" ] || cp "$(dirname "$lib")/$file" "$out/bin/"
    done
    chmod a+x "$out"/bin/*                               # zip files keep no mode here
    find "$work/unpacked" \( -name esminiLib.hpp -o -name esminiRMLib.hpp \) -exec cp {} "$out/include/" \;
    rm -rf "$2"
    mkdir -p "$(dirname "$2")"
    mv "$out" "$2"
)

# 1. ESMINI_HOME
if [ -n "${ESMINI_HOME:-}" ]; then
    usable "$ESMINI_HOME" && used "ESMINI_HOME=$ESMINI_HOME ($version); keep ESMINI_HOME set when running scenweave"
    tried+=("ESMINI_HOME: $problem")
    notes+=("ESMINI_HOME skipped: $problem")
else
    tried+=("ESMINI_HOME unset")
fi

# 2. the workplace copy
if [ -d "$WORKPLACE" ]; then
    home=$(cd "$WORKPLACE" && pwd)
    usable "$home" && used "the workplace copy $home ($version)"
    tried+=("workplace copy: $problem")
else
    tried+=("no workplace copy ../shared/esmini")
fi

# 3. a source archive, built once per archive content
if [ -n "${ESMINI_SOURCE_ARCHIVE:-}" ]; then
    archive=$ESMINI_SOURCE_ARCHIVE
    if [ ! -f "$archive" ]; then
        problem="no such file $archive"
    else
        sha=$(sha256sum "$archive" | cut -d ' ' -f 1)
        stamp="source-archive sha256=$sha $(basename "$archive")"
        what="a build of ESMINI_SOURCE_ARCHIVE=$archive in $PREFIX"
        if [ "$(stamp_of "$PREFIX")" = "$stamp" ] && usable "$PREFIX"; then
            used "$what ($version; already installed)"
        fi
        cached=$CACHE/$sha
        how="from the build cache $cached"
        if ! usable "$cached"; then
            mkdir -p "$CACHE"
            log=$CACHE/build-$sha.log
            echo "esmini: building $(basename "$archive") (once per archive; ~6 min on two cores; log: $log)"
            started=$SECONDS
            rm -f "$log"
            checked build_source "$archive" "$cached" "$log" 2>"$log.err"
            if [ "$status" = 0 ]; then
                how="built in $(( (SECONDS - started) / 60 )) min $(( (SECONDS - started) % 60 )) s"
            else
                rm -rf "$cached"
                reason=$(tail -n 1 "$log.err")
                [ -n "$reason" ] || reason=$(tail -n 1 "$log" 2>/dev/null || true)
                problem="build failed: $reason (log: $log)"
            fi
            rm -f "$log.err"
        fi
        if [ -d "$cached" ] && usable "$cached"; then
            checked install_into_prefix "$cached" "$stamp" 2>"$CACHE/install.err"
            if [ "$status" = 0 ] && usable "$PREFIX"; then
                rm -f "$CACHE/install.err"
                used "$what ($version; $how)"
            fi
            [ "$status" = 0 ] || problem="cannot install into $PREFIX: $(tail -n 1 "$CACHE/install.err")"
            rm -f "$CACHE/install.err"
        elif [ -d "$cached" ]; then
            rm -rf "$cached"
        fi
    fi
    tried+=("ESMINI_SOURCE_ARCHIVE: $problem")
    notes+=("ESMINI_SOURCE_ARCHIVE skipped: $problem")
else
    tried+=("ESMINI_SOURCE_ARCHIVE unset")
fi

# 4. what an earlier setup installed
if usable "$PREFIX"; then
    used "the earlier install in $PREFIX ($version; $(stamp_of "$PREFIX"))"
fi

# 5. esmini's release archive, where the internet answers
unpacked=${TMPDIR:-/var/tmp}/scenweave-esmini-release.$$
release_problem=$(checked fetch_release "$RELEASE_URL" "$unpacked" 2>&1 >/dev/null)
if [ -d "$unpacked" ]; then
    if usable "$unpacked"; then
        release_problem=$(checked install_into_prefix "$unpacked" "release $RELEASE_URL" 2>&1 >/dev/null)
        rm -rf "$unpacked"
        usable "$PREFIX" && used "esmini's release archive $RELEASE_URL, installed in $PREFIX ($version)"
        release_problem="cannot install into $PREFIX: $release_problem"
    else
        release_problem="the release's $problem"
    fi
    rm -rf "$unpacked"
fi
tried+=("release archive $RELEASE_URL: $(tail -n 1 <<<"${release_problem:-failed}")")

echo "esmini: not installed, replay will be unavailable (tried: $(joined "${tried[@]}")); set ESMINI_HOME to an esmini folder with bin/libesminiLib.so or ESMINI_SOURCE_ARCHIVE to its source archive and rerun"
