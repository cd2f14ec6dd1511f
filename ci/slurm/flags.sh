# Shared by submit-tiles.sh and submit-frames.sh (sourced): the render flags as the job
# scripts get them, and the check that the promised output exists.

# has_flag NAME ARGS...: true when ARGS hold --NAME V or --NAME=V.
has_flag() {
    local name=$1 a
    shift
    for a in "$@"; do
        case "$a" in --"$name" | --"$name"=*) return 0 ;; esac
    done
    return 1
}

# flag_value NAME ARGS...: V of --NAME V or --NAME=V (the last one), or nothing.
flag_value() {
    local name=$1 v="" prev=""
    shift
    for a in "$@"; do
        case "$a" in --"$name"=*) v=${a#--"$name"=} ;; esac
        [ "$prev" = "--$name" ] && v=$a
        prev=$a
    done
    echo "$v"
}

# without_flag NAME ARGS...: ARGS without --NAME V / --NAME=V, into the array `rest`.
without_flag() {
    local name=$1 skip=0
    shift
    rest=()
    for a in "$@"; do
        if [ $skip = 1 ]; then skip=0; continue; fi
        case "$a" in
        --"$name") skip=1 ;;
        --"$name"=*) ;;
        *) rest+=("$a") ;;
        esac
    done
}

# without_switch NAME ARGS...: ARGS without the switch --NAME (no value), into `rest`.
without_switch() {
    local name=$1
    shift
    rest=()
    for a in "$@"; do
        [ "$a" = "--$name" ] || rest+=("$a")
    done
}

# A job's state as scontrol knows it (COMPLETED, FAILED, CANCELLED, ...), or "unknown"
# once Slurm has forgotten it (MinJobAge).
job_state() {
    scontrol show job "$1" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | head -n 1 | cut -d= -f2 || true
}

# parts_summary PARTS_DIR: the job's parts across its tasks (fragtrace merge --summary:
# parts done, missing by tile and frame with the task that owed each, time per task);
# nothing when the folder holds no part. Its exit status is merge's (1: a part missing).
parts_summary() {
    local files
    shopt -s nullglob
    files=("$1"/*.exr)
    shopt -u nullglob
    [ ${#files[@]} -gt 0 ] || { echo "no parts in $1"; return 1; }
    "${FRAGTRACE:-fragtrace}" merge --summary "${files[@]}"
}
