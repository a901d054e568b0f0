#!/usr/bin/env bash
# A single-node Slurm cluster on this machine (Debian or Ubuntu), to try `stokes experiment
# --slurm` as a cluster user would, and a test that a run through Slurm gives the same results
# as a direct run.
#
#   scripts/slurm-local.sh up     install slurm-wlm and munge if missing, write the config,
#                                 start munged, slurmctld and slurmd, wait until the node is idle
#                                 and run a small array job
#   scripts/slurm-local.sh down   stop the daemons that `up` started
#   scripts/slurm-local.sh test   run experiments/walls-integrators.json --quick directly and
#                                 through Slurm, compare them, resubmit and check that every job
#                                 is skipped; then submit a small run, cancel one of its tasks
#                                 while it renders, check that the run is known to be incomplete
#                                 (no done.json, --collect refuses, no temporary files), resubmit
#                                 and check that only the cancelled job renders; and check that
#                                 the daemons and the node are as they were
#   scripts/slurm-local.sh        up, then test
#
# `up` and `down` need root (they re-run themselves with sudo when it is there); `test` runs as
# the calling user. Environment:
#   STOKES   the stokes binary for `test` (default: target/release/stokes in the repository;
#            build it first with `cargo build --release`)
#   WORK     an empty folder for the test's runs (default: a new folder under /tmp)
#   SLURM_LOCAL_REPLACE=1   let `up` replace a slurm.conf it did not write (kept as a backup)
#   UP_TIMEOUT   seconds `up` waits for the daemons, the node and its test job (default 90)
#   JOB_TIMEOUT  seconds `test` waits for each submission's jobs (default 600)
#
# The daemons run as root, with process tracking by /proc (proctrack/linuxproc) and no task
# plugin, so no cgroup setup is needed (containers included). The node is addressed as
# 127.0.0.1, so the host name does not have to resolve. Files: the config in /etc/slurm/,
# state in /var/spool/slurm-local/, logs in /var/log/slurm-local/, pid files in
# /run/slurm-local/.
set -euo pipefail

REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
SELF="$REPO/scripts/slurm-local.sh"
MARKER="# Written by stokes scripts/slurm-local.sh; it rewrites this file only while this line is here."
CONF_DIR=/etc/slurm # where Debian's daemons and commands read slurm.conf (see find_conf_dir)
CONF="$CONF_DIR/slurm.conf"
STATE=/var/spool/slurm-local
LOGS=/var/log/slurm-local
RUN=/run/slurm-local
STARTED="$RUN/started" # the daemons `up` started, one name a line, for `down`
MUNGE_KEY=/etc/munge/munge.key
MUNGE_PID=/run/munge/munged.pid
UP_TIMEOUT=${UP_TIMEOUT:-90}      # seconds for the daemons and the node to come up
JOB_TIMEOUT=${JOB_TIMEOUT:-600}   # seconds for the test's Slurm jobs
# The daemons read this file; a SLURM_CONF from the environment would point them elsewhere.
unset SLURM_CONF

step() { printf '\n==> %s\n' "$*"; }
info() { printf '    %s\n' "$*"; }
die() {
    printf '\nslurm-local: error: %s\n' "$*" >&2
    exit 1
}

# ---------------------------------------------------------------------------------------------
# up / down

need_root() {
    [[ $(id -u) -eq 0 ]] && return 0
    if command -v sudo >/dev/null; then
        info "not root: running 'sudo $SELF $1'"
        exec sudo --preserve-env=UP_TIMEOUT,SLURM_LOCAL_REPLACE "$SELF" "$1"
    fi
    die "'$1' needs root (installing packages, starting daemons); run it as root"
}

# The pid in pid file $1 if that process is running and is named $2, else nothing.
live_pid() {
    local pid
    [[ -r $1 ]] || return 1
    pid=$(tr -dc '0-9' <"$1")
    [[ -n $pid && -r /proc/$pid/comm && $(cat "/proc/$pid/comm") == "$2" ]] || return 1
    echo "$pid"
}

install_packages() {
    local missing=()
    for c in sbatch slurmctld slurmd munged; do
        command -v "$c" >/dev/null || missing+=("$c")
    done
    if [[ ${#missing[@]} -eq 0 ]]; then
        info "slurm-wlm and munge are installed ($(slurmd -V))"
        return
    fi
    command -v apt-get >/dev/null || die "missing ${missing[*]} and no apt-get to install them"
    info "missing ${missing[*]}: installing slurm-wlm and munge with apt-get"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q
    apt-get install -y -q --no-install-recommends slurm-wlm munge
    info "installed $(slurmd -V)"
}

record_started() { grep -qsx "$1" "$STARTED" || echo "$1" >>"$STARTED"; }

# Older Ubuntu packages read /etc/slurm-llnl/ instead (known once the packages are installed).
find_conf_dir() {
    if [[ ! -d /etc/slurm && -d /etc/slurm-llnl ]]; then
        CONF_DIR=/etc/slurm-llnl
        CONF="$CONF_DIR/slurm.conf"
    fi
}

munge_works() { munge -n </dev/null 2>/dev/null | unmunge >/dev/null 2>&1; }

start_munge() {
    if [[ ! -s $MUNGE_KEY ]]; then
        info "creating the munge key $MUNGE_KEY"
        install -d -o munge -g munge -m 0700 "$(dirname "$MUNGE_KEY")"
        if command -v mungekey >/dev/null; then
            mungekey --create --keyfile="$MUNGE_KEY"
        else
            dd if=/dev/urandom of="$MUNGE_KEY" bs=1024 count=1 status=none
        fi
        chown munge:munge "$MUNGE_KEY"
        chmod 0400 "$MUNGE_KEY"
    fi
    if munge_works; then
        info "munged is running"
        return
    fi
    # Without systemd nothing creates munged's runtime folder (/run is a fresh tmpfs).
    install -d -o munge -g munge -m 0755 /run/munge
    info "starting: runuser -u munge -- munged"
    runuser -u munge -- munged || die "munged did not start; see /var/log/munge/munged.log"
    record_started munged
    for _ in $(seq 20); do
        munge_works && return
        sleep 0.5
    done
    tail -n 20 /var/log/munge/munged.log >&2 || true
    die "munged started but 'munge -n | unmunge' fails"
}

# slurm.conf for this machine, on stdout.
slurm_conf() {
    local host node
    host=$(hostname -s)
    [[ -n $host ]] || die "this machine has no host name (hostname -s is empty)"
    # The node as slurmd sees it (CPUs, sockets, cores, threads, memory), without the uptime.
    node=$(slurmd -C | awk 'NR == 1' | sed -e 's/^NodeName=[^ ]* //' -e 's/ *UpTime=.*//')
    [[ $node == *CPUs=* ]] || die "cannot read this machine's resources from 'slurmd -C'"
    cat <<EOF
$MARKER
# A single-node cluster on localhost for trying stokes' Slurm support; \`$SELF up\`
# writes it from \`slurmd -C\`, \`$SELF down\` stops the daemons.
ClusterName=stokes-local
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
# No cgroups: processes are tracked through /proc, tasks are not bound or limited.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
# Run the main scheduling loop every second: waiting array tasks start within a second of a
# free CPU instead of about three, which matters for short jobs.
SchedulerParameters=sched_interval=1
# A node that comes back (daemons restarted) returns to service by itself.
ReturnToService=2
StateSaveLocation=$STATE/slurmctld
SlurmdSpoolDir=$STATE/slurmd
SlurmctldPidFile=$RUN/slurmctld.pid
SlurmdPidFile=$RUN/slurmd.pid
SlurmctldLogFile=$LOGS/slurmctld.log
SlurmdLogFile=$LOGS/slurmd.log
NodeName=$host NodeAddr=127.0.0.1 $node State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
}

# Write slurm.conf; returns 0 when it changed.
write_conf() {
    local new
    new=$(slurm_conf)
    if [[ -e $CONF ]] && ! grep -qxF "$MARKER" "$CONF"; then
        if [[ ${SLURM_LOCAL_REPLACE:-} != 1 ]]; then
            die "$CONF exists and was not written by this script, so it is left alone.
    Move it away, or run with SLURM_LOCAL_REPLACE=1 to keep it as a backup and replace it."
        fi
        local backup
        backup="$CONF.before-slurm-local.$(date +%Y%m%d-%H%M%S)"
        cp -p "$CONF" "$backup"
        info "backed up $CONF to $backup"
    elif [[ -e $CONF && $(cat "$CONF") == "$new" ]]; then
        info "$CONF is up to date"
        return 1
    fi
    install -d -m 0755 "$CONF_DIR"
    printf '%s\n' "$new" >"$CONF.tmp.$$"
    chmod 0644 "$CONF.tmp.$$"
    mv -f "$CONF.tmp.$$" "$CONF"
    info "wrote $CONF:"
    grep -E '^(SlurmctldHost|NodeName|PartitionName)=' "$CONF" | sed 's/^/      /'
    return 0
}

# Stop daemon $1 (slurmctld, slurmd, munged) through its pid file $2; waits for it to exit.
stop_daemon() {
    local pid
    pid=$(live_pid "$2" "$1") || {
        info "$1 is not running"
        return 0
    }
    info "stopping $1 (pid $pid)"
    kill -TERM "$pid"
    for _ in $(seq 60); do
        [[ -d /proc/$pid ]] || return 0
        sleep 0.5
    done
    die "$1 (pid $pid) did not stop within 30 s"
}

start_slurm() {
    local changed=$1
    if [[ $changed == 1 ]]; then
        # Node definitions are read only at start: restart daemons running an older config.
        local d
        for d in slurmd slurmctld; do
            if live_pid "$RUN/$d.pid" "$d" >/dev/null; then
                info "the config changed: restarting $d"
                stop_daemon "$d" "$RUN/$d.pid"
            fi
        done
    fi
    if live_pid "$RUN/slurmctld.pid" slurmctld >/dev/null; then
        info "slurmctld is running"
    else
        info "starting: slurmctld"
        slurmctld || die "slurmctld did not start; see $LOGS/slurmctld.log"
        record_started slurmctld
    fi
    local ok=
    for _ in $(seq $((UP_TIMEOUT * 2))); do
        if scontrol ping 2>/dev/null | grep -q 'is UP'; then ok=1 && break; fi
        sleep 0.5
    done
    [[ -n $ok ]] || {
        tail -n 30 "$LOGS/slurmctld.log" >&2 || true
        die "slurmctld does not answer 'scontrol ping' after ${UP_TIMEOUT}s (log above)"
    }
    if live_pid "$RUN/slurmd.pid" slurmd >/dev/null; then
        info "slurmd is running"
    else
        info "starting: slurmd"
        slurmd || die "slurmd did not start; see $LOGS/slurmd.log"
        record_started slurmd
    fi
}

wait_idle() {
    local host state resumed='' t0=$SECONDS
    host=$(hostname -s)
    while :; do
        state=$(sinfo -h -n "$host" -o '%T' 2>/dev/null | head -n 1) || state=''
        case $state in
        idle | mixed | allocated | completing)
            info "node $host is $state ($((SECONDS - t0)) s)"
            return
            ;;
        down* | drain* | fail*)
            # Left down by an earlier run (e.g. a daemon killed): bring it back once.
            if [[ -z $resumed && $((SECONDS - t0)) -ge 5 ]]; then
                info "node $host is $state; resuming it"
                scontrol update NodeName="$host" State=RESUME || true
                resumed=1
            fi
            ;;
        esac
        if ((SECONDS - t0 >= UP_TIMEOUT)); then
            sinfo -N -l >&2 || true
            sinfo -R >&2 || true
            tail -n 20 "$LOGS/slurmd.log" "$LOGS/slurmctld.log" >&2 || true
            die "node $host is '${state:-unknown}', not idle, after ${UP_TIMEOUT}s (state and logs above)"
        fi
        sleep 1
    done
}

smoke_test() {
    local id states
    info "sbatch --array=0-1 --wrap 'true'"
    id=$(sbatch --parsable --array=0-1 --job-name=slurm-local-check --output=/dev/null \
        --wrap 'true') || die "sbatch failed; see $LOGS/slurmctld.log"
    id=${id%%;*}
    for _ in $(seq $((UP_TIMEOUT * 4))); do
        # Both tasks listed as ended (ended jobs stay listed for a while with -t all).
        states=$(squeue -h -t all -j "$id" -o '%T' 2>/dev/null | sort -u | paste -sd, -) ||
            states=''
        case $states in
        COMPLETED) info "a 2-task array job ran to completion" && return ;;
        *FAILED* | *CANCELLED* | *TIMEOUT* | *NODE_FAIL*)
            die "the array job $id ended $states; see $LOGS/slurmd.log and $LOGS/slurmctld.log" ;;
        esac
        sleep 0.25
    done
    scancel "$id" || true
    die "the array job $id did not complete within ${UP_TIMEOUT}s (states: $states); see $LOGS/slurmd.log"
}

cmd_up() {
    need_root up
    local t0=$SECONDS changed=0
    step "packages"
    install_packages
    find_conf_dir
    step "config"
    if write_conf; then changed=1; fi
    install -d -m 0755 "$RUN" "$STATE/slurmctld" "$STATE/slurmd" "$LOGS"
    step "munge"
    start_munge
    step "slurmctld and slurmd"
    start_slurm "$changed"
    step "waiting for the node"
    wait_idle
    step "smoke test"
    smoke_test
    sinfo
    step "Slurm is up ($((SECONDS - t0)) s); stop it with: $SELF down"
}

cmd_down() {
    need_root down
    step "stopping the daemons started by '$SELF up'"
    if [[ ! -s $STARTED ]]; then
        info "none recorded in $STARTED; nothing to stop"
        return
    fi
    local d
    for d in slurmd slurmctld munged; do
        grep -qx "$d" "$STARTED" || continue
        case $d in
        munged) stop_daemon munged "$MUNGE_PID" ;;
        *) stop_daemon "$d" "$RUN/$d.pid" ;;
        esac
    done
    rm -f "$STARTED"
    info "stopped"
}

# ---------------------------------------------------------------------------------------------
# test

# The job names in the run folder's sbatch scripts, one a line.
job_names() {
    sed -n 's/^#SBATCH --job-name=//p' "$1/slurm/array.sbatch" "$1/slurm/collect.sbatch"
}

print_logs() {
    local f
    for f in "$1"/slurm/logs/*; do
        [[ -f $f ]] || continue
        printf -- '--- %s (last 40 lines)\n' "$f"
        tail -n 40 "$f"
    done
}

# Wait until the Slurm jobs of run folder $1 submitted at or after time $2 (YYYY-MM-DDTHH:MM:SS)
# have ended; fails when one did not complete, when nothing shows up, or after JOB_TIMEOUT.
wait_jobs() {
    local run=$1 since=$2 t0=$SECONDS names lines active failed seen='' last=0
    names=$(job_names "$run" | paste -sd, -)
    [[ -n $names ]] || die "no job names in $run/slurm/*.sbatch"
    info "waiting for the jobs $names (up to ${JOB_TIMEOUT}s)"
    while :; do
        # Ended jobs stay listed (state COMPLETED, FAILED, ...) for a few minutes with -t all.
        # (A failed squeue, e.g. the controller busy, counts as "no news" for this round.)
        lines=$(squeue -h -t all -n "$names" -o '%i|%j|%T|%r|%V' 2>/dev/null |
            awk -F'|' -v s="$since" '$5 >= s') || lines=''
        [[ -n $lines ]] && seen=1
        active=$(awk -F'|' 'NF && $3 ~ /^(PENDING|RUNNING|CONFIGURING|COMPLETING|SUSPENDED|REQUEUED|RESIZING|STAGE_OUT)$/' <<<"$lines")
        failed=$(awk -F'|' 'NF && ($3 !~ /^(COMPLETED|PENDING|RUNNING|CONFIGURING|COMPLETING|SUSPENDED|REQUEUED|RESIZING|STAGE_OUT)$/ || $4 == "DependencyNeverSatisfied")' <<<"$lines")
        if [[ -n $failed ]]; then
            printf '%s\n' "$failed" | sed 's/^/      /' >&2
            print_logs "$run" >&2
            awk -F'|' '{print $1}' <<<"$active" | xargs -r scancel || true
            die "a Slurm job of $run did not complete (above: id|name|state|reason|submitted, then the logs); its other jobs were cancelled"
        fi
        if [[ -n $seen && -z $active ]]; then
            info "all jobs completed ($((SECONDS - t0)) s)"
            return
        fi
        if [[ -z $seen ]] && ((SECONDS - t0 >= 30)); then
            die "no Slurm jobs named $names submitted since $since"
        fi
        if ((SECONDS - t0 >= JOB_TIMEOUT)); then
            printf '%s\n' "$active" | sed 's/^/      /' >&2
            print_logs "$run" >&2
            awk -F'|' '{print $1}' <<<"$active" | xargs -r scancel || true
            die "the Slurm jobs of $run did not finish within ${JOB_TIMEOUT}s (above: the unfinished ones, which were cancelled, and the logs)"
        fi
        if ((SECONDS - last >= 15)); then
            info "pending or running: $(awk -F'|' '{printf "%s%s", (NR > 1 ? " " : ""), $1}' <<<"$active" | cut -c1-90) ($((SECONDS - t0)) s)"
            last=$SECONDS
        fi
        sleep 2
    done
}

# Columns of CSV $1 named in $2 (comma-separated), found by the header's names; one line a row.
csv_columns() {
    awk -F, -v cols="$2" '
        BEGIN { n = split(cols, want, ",") }
        NR == 1 {
            for (i = 1; i <= NF; i++) at[$i] = i
            for (k = 1; k <= n; k++)
                if (!(want[k] in at)) { print "no column " want[k] " in " FILENAME > "/dev/stderr"; exit 3 }
            next
        }
        { s = $(at[want[1]]); for (k = 2; k <= n; k++) s = s "," $(at[want[k]]); print s }
    ' "$1"
}

SUMMARY=()
FAILURES=0
result() { # check, direct, slurm, ok|DIFFERENT
    SUMMARY+=("$(printf '%-34s %-14s %-14s %s' "$@")")
    [[ $4 == ok ]] || FAILURES=$((FAILURES + 1))
}

compare_runs() {
    local direct=$1 slurm=$2 keys=variant,integrator,mode,budget,repeat,seed,region,pixels
    local a="$direct/reference.exr" b="$slurm/reference.exr" m1="$direct/metrics.csv" m2="$slurm/metrics.csv"
    local f
    for f in "$a" "$b" "$m1" "$m2"; do [[ -f $f ]] || die "missing $f"; done
    if cmp -s "$a" "$b"; then
        result reference.exr "$(stat -c %s "$a") B" "$(stat -c %s "$b") B" ok
    else
        result reference.exr "$(stat -c %s "$a") B" "$(stat -c %s "$b") B" DIFFERENT
    fi
    if [[ $(head -n 1 "$m1") == "$(head -n 1 "$m2")" ]]; then
        result "metrics.csv header" same same ok
    else
        result "metrics.csv header" "" "" DIFFERENT
        diff <(head -n 1 "$m1" | tr , '\n') <(head -n 1 "$m2" | tr , '\n') | sed 's/^/      /' || true
    fi
    local r1 r2
    r1=$(($(wc -l <"$m1") - 1))
    r2=$(($(wc -l <"$m2") - 1))
    if [[ $r1 -eq $r2 ]]; then result "metrics.csv rows" "$r1" "$r2" ok; else result "metrics.csv rows" "$r1" "$r2" DIFFERENT; fi
    local k1 k2
    k1=$(csv_columns "$m1" "$keys") || die "cannot read the columns $keys of $m1"
    k2=$(csv_columns "$m2" "$keys") || die "cannot read the columns $keys of $m2"
    if [[ $k1 == "$k2" ]]; then
        result "metrics.csv key columns (*)" same same ok
    else
        result "metrics.csv key columns (*)" "" "" DIFFERENT
        info "rows that differ in $keys (< direct, > Slurm):"
        diff <(printf '%s\n' "$k1") <(printf '%s\n' "$k2") | head -n 20 | sed 's/^/      /' || true
    fi
}

# Submit the finished run again; every job must report that it was already finished, and the
# collected results must stay as they are.
check_resubmission() {
    local run=$1 jobs last i before=() skipped=0 since sums
    last=$(sed -n 's/^#SBATCH --array=0-\([0-9]*\).*/\1/p' "$run/slurm/array.sbatch")
    [[ -n $last ]] || die "no '#SBATCH --array=0-N' line in $run/slurm/array.sbatch"
    jobs=$((last + 1))
    for ((i = 0; i < jobs; i++)); do
        before[i]=$(wc -l 2>/dev/null <"$run/slurm/logs/job-$i.out" || echo 0)
    done
    sums=$(cd "$run" && sha256sum reference.exr metrics.csv)
    since=$(date +%Y-%m-%dT%H:%M:%S)
    bash "$run/slurm/submit.sh" 2>&1 | sed 's/^/      /' || die "bash $run/slurm/submit.sh failed (above)"
    wait_jobs "$run" "$since"
    for ((i = 0; i < jobs; i++)); do
        if tail -n +"$((before[i] + 1))" "$run/slurm/logs/job-$i.out" 2>/dev/null | grep -q 'already finished'; then
            skipped=$((skipped + 1))
        else
            info "job $i did not report 'already finished'; its log since the resubmission:"
            tail -n +"$((before[i] + 1))" "$run/slurm/logs/job-$i.out" 2>/dev/null | sed 's/^/      /' || true
        fi
    done
    if [[ $skipped -eq $jobs ]]; then
        result "resubmitted jobs skipped" "-" "$skipped/$jobs" ok
    else
        result "resubmitted jobs skipped" "-" "$skipped/$jobs" DIFFERENT
    fi
    if [[ $(cd "$run" && sha256sum reference.exr metrics.csv) == "$sums" ]]; then
        result "results after resubmission" "-" unchanged ok
    else
        result "results after resubmission" "-" changed DIFFERENT
    fi
}

# ---------------------------------------------------------------------------------------------
# test: a task cancelled while it renders

CANCEL_JOBS=() # Slurm job ids of the cancel check, cancelled if the test stops early

# On the way out of a failed test: cancel the jobs of the cancel check that may still be
# queued (the collect job waits forever once a task was cancelled).
cancel_leftovers() {
    local rc=$?
    if [[ $rc -ne 0 && ${#CANCEL_JOBS[@]} -gt 0 ]]; then
        scancel "${CANCEL_JOBS[@]}" 2>/dev/null || true
        info "cancelled the Slurm jobs of the cancel check, if still queued: ${CANCEL_JOBS[*]}"
    fi
    return "$rc"
}

now() { date +%s.%N; }
# Seconds from time $1 (from `now`) to time $2 (default: now), one decimal.
took() { awk -v a="$1" -v b="${2:-$(now)}" 'BEGIN { printf "%.1f", b - a }'; }

# Seconds in squeue's %M time (M:SS, H:MM:SS or D-H:MM:SS).
squeue_seconds() {
    awk -v t="$1" 'BEGIN {
        d = 0
        if (index(t, "-")) { split(t, a, "-"); d = a[1]; t = a[2] }
        n = split(t, p, ":"); s = 0
        for (i = 1; i <= n; i++) s = s * 60 + p[i]
        print d * 86400 + s
    }'
}

# The state of each task of array job $1, "ID|STATE|TIME" a line (ended tasks included).
array_tasks() { squeue -h -r -t all -j "$1" -o '%i|%T|%M' 2>/dev/null || true; }

# The state of Slurm job $1 ("STATE|REASON"), nothing when it is not listed.
job_state() { squeue -h -t all -j "$1" -o '%T|%r' 2>/dev/null | head -n 1 || true; }

is_active() { [[ $1 =~ ^(PENDING|RUNNING|CONFIGURING|COMPLETING|SUSPENDED|REQUEUED|RESIZING|STAGE_OUT)$ ]]; }

# Plan a small run through Slurm, cancel one task while it renders, and check that the run knows
# it is incomplete: the job has no done.json, `--collect` refuses and names it, INCOMPLETE stays,
# no temporary file is left. Then resubmit: only that job renders, the others are skipped, and
# the run is collected.
check_cancel() {
    local stokes=$1 work=$2
    local run="$work/cancel-run" config="$work/slurm-cancel.json" scene="$REPO/scenes/fluorescent-walls.json"
    local t_all t0 t_submit t_wait t_stop t_rest t_resub out array collect idx task dir log jobs
    local line state used i rc list
    t_all=$(now)
    [[ $scene != *[\"\\]* ]] || die "the repository path $REPO has a quote or backslash; it cannot go into JSON as it is"
    # Two variants of 4 s after eight reference shards of 2 spp: about 10 s through Slurm.
    cat >"$config" <<EOF
{
  "name": "slurm-cancel",
  "comment": "scripts/slurm-local.sh test: one variant task of this run is cancelled while it renders, then the run is resubmitted.",
  "scene": "$scene",
  "reference": { "integrator": "pt-hero", "spp": 16, "seed": 3 },
  "variants": [
    { "name": "pt-mono", "integrator": "pt-mono" },
    { "name": "pt-hero", "integrator": "pt-hero" }
  ],
  "budget": { "seconds": [4] },
  "threads": 1
}
EOF
    info "config $config"
    info "$stokes experiment $config --slurm --out $run"
    t0=$(now)
    out=$("$stokes" experiment "$config" --slurm --out "$run" 2>"$work/cancel-submit.err") || {
        sed 's/^/      /' "$work/cancel-submit.err" >&2
        die "planning or submitting the cancel check's run failed (above)"
    }
    sed 's/^/      /' "$work/cancel-submit.err"
    read -r array collect _ <<<"$(tail -n 1 <<<"$out")" || true
    [[ $array =~ ^[0-9]+$ && $collect =~ ^[0-9]+$ ]] ||
        die "stokes printed '$out' on stdout, not 'ARRAY_ID COLLECT_ID'"
    CANCEL_JOBS=("$array" "$collect")
    t_submit=$(took "$t0")
    info "array job $array, collect job $collect (planned and submitted in $t_submit s)"

    # The first variant job: its task is cancelled once it has rendered for a second.
    idx=$(grep -m 1 '"kind":"variant"' "$run/jobs.jsonl" | grep -o '"index":[0-9]*' | head -n 1 | cut -d: -f2) || true
    [[ -n $idx ]] || die "no job with \"kind\":\"variant\" in $run/jobs.jsonl"
    jobs=$(grep -c . "$run/jobs.jsonl")
    task="${array}_$idx"
    dir="$run/jobs/$(printf '%05d' "$idx")"
    log="$run/slurm/logs/job-$idx.out"
    info "waiting for task $task (job $idx of $jobs, a variant) to render for a second"
    t0=$(now)
    while :; do
        line=$(array_tasks "$array" | awk -F'|' -v t="$task" '$1 == t')
        IFS='|' read -r _ state used <<<"$line" || true
        if [[ $state == RUNNING ]] && (($(squeue_seconds "$used") >= 1)) &&
            grep -qs "^job $idx (" "$log"; then
            break
        fi
        if [[ -n $state ]] && ! is_active "$state"; then
            array_tasks "$array" | sed 's/^/      /' >&2
            print_logs "$run" >&2
            die "task $task ended ($state) before it could be cancelled (above: the tasks and the logs)"
        fi
        if (($(awk -v t="$(took "$t0")" 'BEGIN { print int(t) }') >= JOB_TIMEOUT)); then
            array_tasks "$array" | sed 's/^/      /' >&2
            die "task $task did not run within ${JOB_TIMEOUT}s (state '${state:-not listed}'; tasks above)"
        fi
        sleep 0.2
    done
    t_wait=$(took "$t0")
    info "task $task is RUNNING ($used), ${t_wait} s after the submission: scancel $task"
    t0=$(now)
    scancel "$task" || die "scancel $task failed"
    while :; do
        state=$(array_tasks "$array" | awk -F'|' -v t="$task" '$1 == t { print $2 }')
        [[ -n $state ]] && ! is_active "$state" && break
        (($(awk -v t="$(took "$t0")" 'BEGIN { print int(t) }') < 60)) ||
            die "task $task is still '${state:-not listed}' 60 s after scancel"
        sleep 0.2
    done
    t_stop=$(took "$t0")
    info "task $task ended $state ${t_stop} s after scancel; its log:"
    sed 's/^/      /' "$log"
    # Slurm sends SIGTERM, then SIGKILL after KillWait (30 s): a quick stop means the job exited
    # on SIGTERM, and stokes says so when it removed its temporary files.
    if [[ $state == CANCELLED ]] && grep -q 'interrupted (signal 15)' "$log"; then
        result "cancel: task stopped on SIGTERM" "-" "${t_stop} s" ok
    else
        result "cancel: task stopped on SIGTERM" "-" "$state" DIFFERENT
    fi

    info "waiting for the other tasks of array job $array"
    t0=$(now)
    while :; do
        out=$(array_tasks "$array")
        [[ -n $out ]] && ! awk -F'|' '{ print $2 }' <<<"$out" | grep -qE '^(PENDING|RUNNING|CONFIGURING|COMPLETING|SUSPENDED|REQUEUED|RESIZING|STAGE_OUT)$' && break
        (($(awk -v t="$(took "$t0")" 'BEGIN { print int(t) }') < JOB_TIMEOUT)) || {
            printf '%s\n' "$out" | sed 's/^/      /' >&2
            print_logs "$run" >&2
            die "array job $array did not finish within ${JOB_TIMEOUT}s (tasks and logs above)"
        }
        sleep 0.5
    done
    t_rest=$(took "$t0")
    # Every task but the cancelled one completed, and all of them are listed.
    if [[ $(awk -F'|' -v t="$task" '$1 != t && $2 == "COMPLETED"' <<<"$out" | grep -c .) -ne $((jobs - 1)) ]]; then
        printf '%s\n' "$out" | sed 's/^/      /' >&2
        print_logs "$run" >&2
        die "the tasks of array job $array other than $task did not all complete (above: id|state|time, then the logs)"
    fi
    info "the other $((jobs - 1)) tasks completed (${t_rest} s after the cancel)"

    # afterok cannot be satisfied any more: the collect job must stay pending and never start.
    t0=$(now)
    while :; do
        line=$(job_state "$collect")
        [[ $line == "PENDING|DependencyNeverSatisfied" ]] && break
        [[ $line == PENDING* ]] || break
        (($(awk -v t="$(took "$t0")" 'BEGIN { print int(t) }') < 20)) || break
        sleep 0.5
    done
    info "collect job $collect: ${line:-not listed} (state|reason); scancel $collect"
    if [[ $line == PENDING* ]]; then
        result "cancel: collect job held back" "-" "pending" ok
    else
        result "cancel: collect job held back" "-" "${line%%|*}" DIFFERENT
    fi
    scancel "$collect" || die "scancel $collect failed"

    if [[ -e $dir/done.json ]]; then
        result "cancel: job has no done.json" "-" "done.json" DIFFERENT
    else
        result "cancel: job has no done.json" "-" "none" ok
    fi
    info "the cancelled job's folder $dir:"
    if [[ -d $dir ]]; then
        (cd "$dir" && ls -laR) | sed 's/^/      /'
    else
        info "  (not there)"
    fi
    local leftovers
    leftovers=$(find "$dir" -name '*.tmp*' 2>/dev/null | grep -c .) || true
    if [[ $leftovers -eq 0 ]]; then
        result "cancel: temporary files left" "-" "0" ok
    else
        find "$dir" -name '*.tmp*' | sed 's/^/      /'
        result "cancel: temporary files left" "-" "$leftovers" DIFFERENT
    fi

    info "$stokes experiment --collect $run (must exit 2 and name job $idx)"
    rc=0
    "$stokes" experiment --collect "$run" >"$work/cancel-collect.out" 2>"$work/cancel-collect.err" || rc=$?
    sed 's/^/      /' "$work/cancel-collect.out" "$work/cancel-collect.err"
    list=$(sed -n 's/.*missing (never ran, still running, or killed): *//p' "$work/cancel-collect.err" | head -n 1)
    if [[ $rc -eq 2 && $list == "$idx" ]]; then
        result "cancel: collect refuses, names job" "-" "exit 2: $list" ok
    else
        result "cancel: collect refuses, names job" "-" "exit $rc: ${list:-?}" DIFFERENT
    fi
    if [[ -e $run/INCOMPLETE ]]; then
        result "cancel: INCOMPLETE kept" "-" "kept" ok
    else
        result "cancel: INCOMPLETE kept" "-" "gone" DIFFERENT
    fi

    # Resubmit: only the cancelled job renders; the others report that they already finished
    # (the logs are appended, so count the reports before and after).
    local before=() skipped=0 since n
    for ((i = 0; i < jobs; i++)); do
        before[i]=$(grep -cs 'already finished' "$run/slurm/logs/job-$i.out") || true
    done
    since=$(date +%Y-%m-%dT%H:%M:%S)
    info "resubmitting: bash $run/slurm/submit.sh"
    t0=$(now)
    out=$(bash "$run/slurm/submit.sh" 2>&1) || {
        printf '%s\n' "$out" | sed 's/^/      /' >&2
        die "bash $run/slurm/submit.sh failed (above)"
    }
    printf '%s\n' "$out" | sed 's/^/      /'
    # Job ids for cleanup if the test stops early ("array job: N (...)", "collect job: N (...)").
    local ids=()
    read -r -a ids <<<"$(sed -n 's/^\(array\|collect\) job: \([0-9]*\).*/\2/p' <<<"$out" | paste -sd ' ' -)" || true
    CANCEL_JOBS+=("${ids[@]}")
    wait_jobs "$run" "$since"
    t_resub=$(took "$t0")
    for ((i = 0; i < jobs; i++)); do
        [[ $i -eq $idx ]] && continue
        n=$(grep -cs 'already finished' "$run/slurm/logs/job-$i.out") || true
        if [[ $n -gt ${before[i]} ]]; then
            skipped=$((skipped + 1))
        else
            info "job $i did not report 'already finished' again; its log:"
            tail -n 5 "$run/slurm/logs/job-$i.out" 2>/dev/null | sed 's/^/      /' || true
        fi
    done
    if [[ $skipped -eq $((jobs - 1)) ]]; then
        result "resubmit: finished jobs skipped" "-" "$skipped/$((jobs - 1))" ok
    else
        result "resubmit: finished jobs skipped" "-" "$skipped/$((jobs - 1))" DIFFERENT
    fi
    n=$(grep -cs 'already finished' "$log") || true
    if [[ -f $dir/done.json && $n -eq ${before[idx]} ]] && grep -q "^job $idx done in" "$log"; then
        result "resubmit: cancelled job rendered" "-" "done" ok
    else
        info "the log of job $idx:"
        sed 's/^/      /' "$log"
        result "resubmit: cancelled job rendered" "-" "not done" DIFFERENT
    fi
    if [[ -f $run/run.json && -f $run/metrics.csv && ! -e $run/INCOMPLETE ]]; then
        result "resubmit: collected, no INCOMPLETE" "-" "run.json" ok
    else
        print_logs "$run" >&2
        result "resubmit: collected, no INCOMPLETE" "-" "missing" DIFFERENT
    fi
    CANCEL_TIMES="submit ${t_submit} s, task rendering after ${t_wait} s, stopped ${t_stop} s after scancel, other tasks ${t_rest} s, resubmission ${t_resub} s; $(took "$t_all") s in all"
    info "timings: $CANCEL_TIMES"
}

# The pids of the Slurm and munge daemons, to check that the test leaves them alone.
daemon_pids() {
    printf 'slurmctld=%s slurmd=%s munged=%s' "$(live_pid "$RUN/slurmctld.pid" slurmctld || true)" \
        "$(live_pid "$RUN/slurmd.pid" slurmd || true)" "$(live_pid "$MUNGE_PID" munged || true)"
}

# The test leaves the cluster as it found it: the same daemons ($1, from daemon_pids), the node
# not drained (a task that cannot be killed drains it), and no job of its run folders ($3...)
# submitted since $2 still queued.
check_cluster() {
    local daemons=$1 since=$2 names state queued
    shift 2
    info "daemons: $(daemon_pids)"
    if [[ $(daemon_pids) == "$daemons" ]]; then
        result "daemons unchanged" "-" "same pids" ok
    else
        info "before the test: $daemons"
        result "daemons unchanged" "-" "changed" DIFFERENT
    fi
    state=$(sinfo -h -n "$(hostname -s)" -o '%T' 2>/dev/null | head -n 1) || state=''
    info "node $(hostname -s): ${state:-not listed}"
    case $state in
    idle | mixed | allocated | completing) result "node in service" "-" "$state" ok ;;
    *) result "node in service" "-" "${state:-?}" DIFFERENT ;;
    esac
    names=$(for r in "$@"; do job_names "$r"; done | paste -sd, -)
    queued=$(squeue -h -n "$names" -o '%i|%j|%T|%V' 2>/dev/null | awk -F'|' -v s="$since" '$4 >= s') || queued=''
    if [[ -z $queued ]]; then
        result "no test jobs left queued" "-" "none" ok
    else
        printf '%s\n' "$queued" | sed 's/^/      /'
        result "no test jobs left queued" "-" "$(grep -c . <<<"$queued")" DIFFERENT
    fi
}

cmd_test() {
    local stokes=${STOKES:-$REPO/target/release/stokes} work=${WORK:-} config=experiments/walls-integrators.json
    [[ $stokes == /* ]] || stokes="$PWD/$stokes"
    [[ -x $stokes ]] || die "no stokes binary at $stokes; build it with 'cargo build --release' or set STOKES"
    sinfo -h >/dev/null 2>&1 || die "Slurm does not answer here (sinfo fails); start it with: $SELF up"
    [[ -n $work ]] || work=$(mktemp -d "${TMPDIR:-/tmp}/stokes-slurm-test.XXXXXX")
    mkdir -p "$work"
    work=$(cd "$work" && pwd)
    [[ ! -e $work/direct && ! -e $work/slurm-run && ! -e $work/cancel-run ]] ||
        die "$work already holds direct/, slurm-run/ or cancel-run/; set WORK to an empty folder"
    cd "$REPO"
    local t_test=$SECONDS daemons test_since
    daemons=$(daemon_pids)
    test_since=$(date +%Y-%m-%dT%H:%M:%S)
    trap cancel_leftovers EXIT
    step "test: stokes $stokes, work folder $work"

    step "direct run"
    info "$stokes experiment $config --quick --out $work/direct"
    "$stokes" experiment "$config" --quick --out "$work/direct" || die "the direct run failed (above)"
    local latest="$work/direct/walls-integrators/latest"
    [[ -f $latest ]] || die "the direct run wrote no $latest"
    local direct
    direct="$work/direct/walls-integrators/$(tr -d '\n' <"$latest")"
    [[ -d $direct ]] || die "$latest names $direct, which does not exist"
    info "run folder: $direct"

    step "Slurm run"
    local run="$work/slurm-run" since
    since=$(date +%Y-%m-%dT%H:%M:%S)
    info "$stokes experiment $config --quick --slurm --out $run"
    "$stokes" experiment "$config" --quick --slurm --out "$run" 2>&1 | tee "$work/slurm-submit.log" ||
        die "planning or submitting the Slurm run failed (above)"
    wait_jobs "$run" "$since"
    [[ -f $run/run.json ]] || {
        print_logs "$run" >&2
        die "the Slurm jobs ended but $run/run.json is missing (logs above)"
    }
    info "run folder: $run"

    step "comparing the direct run with the Slurm run"
    compare_runs "$direct" "$run"

    step "resubmitting the finished Slurm run (every job must be skipped)"
    check_resubmission "$run"

    step "job safety: cancelling a running task, then resubmitting"
    check_cancel "$stokes" "$work"

    step "the cluster after the test"
    check_cluster "$daemons" "$test_since" "$run" "$work/cancel-run"

    step "summary"
    printf '    %-34s %-14s %-14s %s\n' check direct slurm result
    printf '    %s\n' "${SUMMARY[@]}"
    info "(*) variant,integrator,mode,budget,repeat,seed,region,pixels, row by row"
    info "cancel check: $CANCEL_TIMES"
    info "test: $((SECONDS - t_test)) s"
    if [[ $FAILURES -gt 0 ]]; then
        die "$FAILURES check(s) failed; the runs are in $work"
    fi
    info "all checks passed; the runs are in $work"
}

case ${1:-} in
up) cmd_up ;;
down) cmd_down ;;
test) cmd_test ;;
"")
    if [[ $(id -u) -eq 0 ]]; then
        cmd_up
    else
        command -v sudo >/dev/null || die "'up' needs root; run it as root, then '$SELF test'"
        sudo --preserve-env=UP_TIMEOUT,SLURM_LOCAL_REPLACE "$SELF" up
    fi
    cmd_test
    ;;
-h | --help | help) sed -n '2,/^set -euo/p' "$SELF" | sed -e '$d' -e 's/^# \{0,1\}//' ;;
*) die "unknown command '$1'; use up, down, test, or nothing for up then test (--help)" ;;
esac
