# Shared set-up for scripts/test, scripts/demo and scripts/bench. Source it; do not run it.
# shellcheck shell=bash

SSM_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
SSM_WS="${SSM_WS:-$SSM_ROOT/.ws}"
SSM_CACHE="${SSM_CACHE:-$SSM_ROOT/.cache}"

# ROS Python tools want Debian's interpreter, not a python3 that happens to be first on PATH.
export PATH="/usr/bin:/bin:$PATH"
export PYTHONNOUSERSITE=1
export ROS_PYTHON_VERSION=3
export ROSCONSOLE_STDOUT_LINE_BUFFERED=1

ssm_log() { printf '[%s] %s\n' "$(basename "$0")" "$*" >&2; }

# Installs the Debian packages in scripts/lib/apt-packages.txt that are missing (quiet when all
# are present; through sudo when not root).
ssm_ensure_packages() {
  local missing=() pkg
  while read -r pkg; do
    [[ -z "$pkg" || "$pkg" == \#* ]] && continue
    if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
      missing+=("$pkg")
    fi
  done < "$SSM_ROOT/scripts/lib/apt-packages.txt"
  [[ ${#missing[@]} -eq 0 ]] && return 0
  local sudo=""
  [[ $(id -u) -ne 0 ]] && sudo="sudo"
  ssm_log "installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" >/dev/null
}

# Makes the catkin workspace overlay (.ws/src/stereo_safety_map -> this repository) and builds
# it in Release with tests. Incremental on a second run.
ssm_build() {
  mkdir -p "$SSM_WS/src"
  local link="$SSM_WS/src/stereo_safety_map"
  if [[ ! -e "$link" ]]; then ln -s "$SSM_ROOT" "$link"; fi
  # ccache, when installed (not required), makes rebuilds in other checkouts cheap.
  local launcher=()
  if command -v ccache > /dev/null; then
    export CCACHE_BASEDIR="$SSM_ROOT" CCACHE_NOHASHDIR=1
    launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
  fi
  # Arguments are passed to catkin_make (targets such as `tests`, or extra -D options).
  (cd "$SSM_WS" && catkin_make -j2 "${launcher[@]}" \
    -DCMAKE_BUILD_TYPE=Release \
    -DCATKIN_ENABLE_TESTING=ON \
    -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
    "$@")
}

ssm_source_ws() {
  # shellcheck disable=SC1091
  set +u
  source "$SSM_WS/devel/setup.bash"
  set -u
}

# Key of a rendered dataset: the scene file, the render options and the renderer's sources. A
# cached bag whose key differs is rendered again, so a changed scene or renderer never leaves a
# stale dataset behind.
ssm_dataset_key() {  # scene render-options...
  local scene="$1"
  shift
  {
    cat "$scene"
    echo "options: $*"
    cat "$SSM_ROOT"/src/dataset/*.cpp "$SSM_ROOT"/src/dataset/*.h \
      "$SSM_ROOT"/include/stereo_safety_map/dataset/*.h \
      "$SSM_ROOT"/src/tools/make_dataset.cpp
  } | sha1sum | cut -d' ' -f1
}

# Renders a scene (all its variants) into a folder unless every expected bag is there with the
# current key. Usage: ssm_render_scene BIN_DIR SCENE OUT_DIR "OPTS" NAME...
ssm_render_scene() {
  local bin="$1" scene="$2" data="$3" opts="$4"
  shift 4
  local key name stale=0
  # shellcheck disable=SC2086
  key=$(ssm_dataset_key "$scene" $opts)
  for name in "$@"; do
    if [[ ! -f "$data/$name.bag" || ! -d "$data/${name}_gt" ||
      "$(cat "$data/$name.key" 2> /dev/null)" != "$key" ]]; then
      stale=1
    fi
  done
  [[ $stale -eq 0 ]] && return 0
  mkdir -p "$data"
  ssm_log "rendering $(basename "$scene") into $data (cached for the next run)"
  # shellcheck disable=SC2086
  "$bin/make_dataset" --scene "$scene" --out "$data" $opts --variant all > "$data/$(basename "$scene" .yaml).log" 2>&1 || {
    cat "$data/$(basename "$scene" .yaml).log" >&2
    return 1
  }
  for name in "$@"; do echo "$key" > "$data/$name.key"; done
}
