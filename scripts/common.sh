# Shared by scripts/demo, scripts/test and scripts/bench: find the repository, install the missing
# Debian packages, configure and build. Sourced, not run. Needs no ROS environment beforehand.

SDS_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SDS_BUILD_DIR="${SDS_BUILD_DIR:-$SDS_ROOT/build}"
SDS_BIN_DIR="$SDS_BUILD_DIR/devel/lib/scale_drift_slam"
SDS_JOBS="${SDS_JOBS:-2}"

# A pyenv python3 first on PATH has no ROS modules (doc/install.md): use Debian's.
export PATH="/usr/bin:/bin:$PATH"
# When ccache is installed (optional, not in the package list) it is used; paths are hashed
# relative to the checkout so that several checkouts share the cache.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$SDS_ROOT}"

sds_log() { printf '\033[1m[scale_drift_slam]\033[0m %s\n' "$*"; }

# Installs the packages of scripts/debian-packages.txt (plus any given as arguments) that are
# missing, with sudo when not root. Runs apt-get update only when something is missing.
sds_install_packages() {
  local wanted=() missing=() pkg
  while read -r pkg; do
    [[ -z "$pkg" || "$pkg" == \#* ]] || wanted+=("$pkg")
  done < "$SDS_ROOT/scripts/debian-packages.txt"
  wanted+=("$@")
  local installed
  installed="$(dpkg-query -W -f='${Package} ${db:Status-Abbrev}\n' "${wanted[@]}" 2>/dev/null |
               awk '$2 ~ /^ii/ {print $1}' || true)"
  for pkg in "${wanted[@]}"; do
    grep -qx "$pkg" <<< "$installed" || missing+=("$pkg")
  done
  if [[ ${#missing[@]} -eq 0 ]]; then
    sds_log "all ${#wanted[@]} Debian packages are installed"
    return 0
  fi
  local sudo=()
  if [[ "$(id -u)" != 0 ]]; then
    command -v sudo > /dev/null || { echo "need root or sudo to install: ${missing[*]}" >&2; return 1; }
    sudo=(sudo)
  fi
  sds_log "installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  "${sudo[@]}" apt-get update -q
  "${sudo[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
}

# Configures (once) and builds the given targets (default: all) in $SDS_BUILD_DIR.
sds_build() {
  local targets=("$@")
  [[ ${#targets[@]} -gt 0 ]] || targets=(all)
  if [[ ! -f "$SDS_BUILD_DIR/CMakeCache.txt" ]]; then
    sds_log "configuring in $SDS_BUILD_DIR"
    mkdir -p "$SDS_BUILD_DIR"
    local launcher=()
    command -v ccache > /dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
    cmake -S "$SDS_ROOT" -B "$SDS_BUILD_DIR" -DCMAKE_BUILD_TYPE=Release "${launcher[@]}" \
      -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
      -DCATKIN_ENABLE_TESTING=ON > "$SDS_BUILD_DIR/configure.log" 2>&1 ||
      { cat "$SDS_BUILD_DIR/configure.log"; return 1; }
  fi
  sds_log "building ${targets[*]} (-j$SDS_JOBS)"
  cmake --build "$SDS_BUILD_DIR" -j "$SDS_JOBS" --target "${targets[@]}"
  sds_link_devel
}

# rosrun skips everything under <package>/build/ (its `find ... ! -regex ".*$pkgdir/build/.*"`),
# the devel space of the default build folder included: "Couldn't find executable". A link
# <package>/devel -> build/devel is searched instead, so that `rosrun scale_drift_slam NODE` works
# after `source build/devel/setup.bash` (doc/ros.md). Made only for the default build folder, and
# never over a real devel folder.
sds_link_devel() {
  [[ "$SDS_BUILD_DIR" == "$SDS_ROOT/build" && -d "$SDS_BUILD_DIR/devel" ]] || return 0
  local link="$SDS_ROOT/devel"
  if [[ -L "$link" || ! -e "$link" ]]; then
    ln -sfn build/devel "$link"
  fi
}

# ROS settings for anything that starts nodes: loopback only, logs inside the build folder.
sds_ros_environment() {
  export ROS_HOSTNAME=localhost
  export ROS_HOME="$SDS_BUILD_DIR/ros_home"
  export ROS_LOG_DIR="$ROS_HOME/log"
  mkdir -p "$ROS_LOG_DIR"
}

# A free TCP port for a ROS master (never the default 11311: other checkouts may run tests).
sds_free_port() {
  /usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("localhost", 0)); print(s.getsockname()[1])'
}
