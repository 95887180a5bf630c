# `scripts/bench --ros`: the ROS replay of a dataset bag through launch/bag_replay.launch, measured
# by scripts/lib/ros_replay_probe.py. Sourced by scripts/bench (uses its option variables: out,
# quick, build, rate, bag, variants, cores); do not run it.
# shellcheck shell=bash
# shellcheck disable=SC2154  # out, quick, build, rate, bag, variants, cores: set by scripts/bench

# A TCP port nobody listens on (for this replay's own roscore: never the shared 11311).
ssm_free_port() {
  /usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

# One replay. Usage: ssm_ros_replay NAME CPU RESULT_JSON LAUNCH_ARGS...  (CPU: -1 = not pinned)
ssm_ros_replay() {
  local name="$1" cpu="$2" result="$3"
  shift 3
  local logs="$out/ros_logs/$name"
  mkdir -p "$logs"
  local port
  port=$(ssm_free_port)
  export ROS_MASTER_URI="http://127.0.0.1:$port"
  export ROS_LOG_DIR="$logs"
  roscore -p "$port" > "$logs/roscore.log" 2>&1 &
  local core_pid=$!
  local _
  for _ in $(seq 1 100); do
    rosparam list > /dev/null 2>&1 && break
    sleep 0.2
  done
  if ! rosparam list > /dev/null 2>&1; then
    ssm_log "$name: roscore on port $port did not come up (see $logs/roscore.log)"
    kill -INT "$core_pid" 2> /dev/null
    wait "$core_pid" 2> /dev/null
    return 1
  fi
  if [[ " $* " == *" disparity:=stereo_image_proc "* ]]; then
    rosparam load "$out/stereo_image_proc_disparity.yaml" /stereo/disparity
  fi
  local probe_args=(--out "$result" --rate "$rate" --tail "$tail")
  [[ "$cpu" -ge 0 ]] && probe_args+=(--cpu "$cpu")
  [[ " $* " == *" obstacles:=false "* ]] || probe_args+=(--extra /obstacles)
  [[ " $* " == *" occupancy_2d:=false "* ]] || probe_args+=(--extra /occupancy_2d)
  /usr/bin/python3 "$SSM_ROOT/scripts/lib/ros_replay_probe.py" "${probe_args[@]}" \
    > "$logs/probe.log" 2>&1 &
  local probe_pid=$!
  ssm_log "$name: replaying $(basename "$bag") at rate $rate (roscore port $port; logs $logs)"
  # The player is required: roslaunch ends (and stops every node) when the bag has been played.
  timeout -s INT 600 roslaunch stereo_safety_map bag_replay.launch bag:="$bag" rate:="$rate" \
    delay:="$delay" "$@" > "$logs/roslaunch.log" 2>&1
  local launch_rc=$?
  wait "$probe_pid"
  local probe_rc=$?
  kill -INT "$core_pid" 2> /dev/null
  wait "$core_pid" 2> /dev/null
  if [[ $probe_rc -ne 0 ]]; then
    ssm_log "$name: no safety map measured (probe exit $probe_rc, roslaunch exit $launch_rc);" \
      "see $logs/probe.log and $logs/roslaunch.log"
    tail -n 20 "$logs/roslaunch.log" >&2
    return 1
  fi
  return 0
}

ssm_bench_ros() {
  if [[ $build -eq 1 ]]; then
    if ! ssm_ensure_packages; then
      ssm_log "could not install the Debian packages this package needs"
      return 1
    fi
    mkdir -p "$SSM_WS/logs"
    ssm_log "building the workspace in $SSM_WS (log: $SSM_WS/logs/build_bench_ros.log)"
    if ! ssm_build > "$SSM_WS/logs/build_bench_ros.log" 2>&1; then
      tail -n 40 "$SSM_WS/logs/build_bench_ros.log" >&2
      ssm_log "build failed"
      return 1
    fi
  fi
  [[ -f "$SSM_WS/devel/setup.bash" ]] || { ssm_log "no workspace in $SSM_WS (build first)"; return 1; }
  ssm_source_ws
  local bin="${SSM_BIN_DIR:-$SSM_WS/devel/lib/stereo_safety_map}"

  local scene="$SSM_ROOT/scenes/dataset1_rail_dropoff_ramp.yaml"
  local name_bag
  name_bag="$(basename "$scene" .yaml)"
  tail=1.0
  delay=4
  if [[ $quick -eq 1 ]]; then
    # Smoke: the small render (320x240, 40 frames over 30 s of bag time) played fast.
    [[ -n "$rate" ]] || rate=10
    variants="default"
    cores="2"
    tail=0
    delay=2
    if [[ -z "$bag" ]]; then
      ssm_render_scene "$bin" "$scene" "$SSM_CACHE/datasets_small" "--small" "$name_bag" || return 1
      bag="$SSM_CACHE/datasets_small/$name_bag.bag"
    fi
  else
    [[ -n "$rate" ]] || rate=2
    if [[ -z "$bag" ]]; then
      ssm_render_scene "$bin" "$scene" "$SSM_CACHE/datasets" "" "$name_bag" || return 1
      bag="$SSM_CACHE/datasets/$name_bag.bag"
    fi
  fi
  [[ -f "$bag" ]] || { ssm_log "no bag $bag"; return 1; }
  mkdir -p "$out"
  rm -rf "$out/ros_runs" "$out/ros_logs"
  mkdir -p "$out/ros_runs"
  /usr/bin/python3 "$SSM_ROOT/scripts/lib/ros_replay_report.py" \
    --sip-params "$SSM_ROOT/config/disparity.yaml" > "$out/stereo_image_proc_disparity.yaml" || return 1
  # Variant "parallel": our disparity nodelet with the right-to-left matcher on its own thread.
  sed -e 's/^parallel_left_right:.*$/parallel_left_right: true/' "$SSM_ROOT/config/disparity.yaml" \
    > "$out/disparity_parallel.yaml"
  grep -q '^parallel_left_right: true' "$out/disparity_parallel.yaml" ||
    echo "parallel_left_right: true" >> "$out/disparity_parallel.yaml"

  # Optional nodelets of bag_replay.launch (the hybrid one exists on some branches).
  local launch="$SSM_ROOT/launch/bag_replay.launch" optional=() arg
  for arg in obstacles occupancy_2d hybrid; do
    grep -q "<arg name=\"$arg\"" "$launch" && optional+=("$arg:=false")
  done

  local load_start nproc_
  load_start=$(cut -d' ' -f1-3 /proc/loadavg)
  nproc_=$(nproc)
  ssm_log "load average now: $load_start on $nproc_ cores"
  local runs=() meta_runs=() v c name cpu args ok=0 total=0 pin_cpu=$((nproc_ - 1))
  for v in ${variants//,/ }; do
    case "$v" in
      default) args=() ;;
      minimal) args=("${optional[@]}") ;;
      parallel) args=(disparity_config:="$out/disparity_parallel.yaml" "${optional[@]}") ;;
      stereo_image_proc) args=(disparity:=stereo_image_proc "${optional[@]}") ;;
      *) ssm_log "unknown variant $v (default, minimal, parallel, stereo_image_proc)"; return 2 ;;
    esac
    for c in ${cores//,/ }; do
      case "$c" in
        2) cpu=-1; name="$v" ;;
        1) cpu=$pin_cpu; name="$v, 1 core" ;;
        *) ssm_log "unknown cores value $c (2 or 1)"; return 2 ;;
      esac
      local result="$out/ros_runs/${v}_$c.json"
      total=$((total + 1))
      if ssm_ros_replay "$name" "$cpu" "$result" "${args[@]}"; then ok=$((ok + 1)); fi
      runs+=("$result")
      meta_runs+=("$(/usr/bin/python3 -c 'import json, sys; print(json.dumps({"name": sys.argv[1], "cores": sys.argv[2], "args": sys.argv[4:], "sip_params": (dict(l.split(": ", 1) for l in open(sys.argv[3]).read().splitlines()) if "disparity:=stereo_image_proc" in sys.argv[4:] else None)}))' \
        "$name" "$([[ $cpu -ge 0 ]] && echo "1 (core $cpu)" || echo "2 (shared)")" \
        "$out/stereo_image_proc_disparity.yaml" "${args[@]}")")
    done
  done
  local load_end
  load_end=$(cut -d' ' -f1-3 /proc/loadavg)
  {
    printf '{"overall": {"bag": "%s", "rate": %s, "load_start": "%s", "load_end": "%s", "nproc": %s, "tail": %s, "quick": %s, "date": "%s"},\n "runs": [' \
      "$(basename "$bag")" "$rate" "$load_start" "$load_end" "$nproc_" "$tail" \
      "$([[ $quick -eq 1 ]] && echo true || echo false)" "$(date -Iseconds)"
    local first=1 m
    for m in "${meta_runs[@]}"; do
      [[ $first -eq 1 ]] || printf ',\n'
      first=0
      printf '%s' "$m"
    done
    printf ']}\n'
  } > "$out/ros_meta.json"
  /usr/bin/python3 "$SSM_ROOT/scripts/lib/ros_replay_report.py" --meta "$out/ros_meta.json" \
    --out-json "$out/ros.json" --out-md "$out/ros.md" "${runs[@]}"
  local report_rc=$?
  ssm_log "load average at the end: $load_end"
  ssm_log "results: $out/ros.json, $out/ros.md ($ok of $total replays gave safety maps)"
  [[ $ok -eq $total && $report_rc -eq 0 ]]
}
