#!/usr/bin/python3
"""The serial share of a threaded run, measured: runs COMMAND (a bench_step or millsim run on 2 or
more threads) under `perf record -e cpu-clock` and counts, per thread, the samples at work and
the samples waiting (the team's idle loop, sched_yield and the kernel's side of it, the force
pass's waits for a higher owner: wait_until_at_least). A worker waits while the calling thread
runs serial code or a longer share; with S the calling thread's samples and w the workers'
samples at work, the part of the calling thread's time during which the other threads had
nothing to do is about (S - w / (T - 1)) / S. Setup (reading a scene, building the gas) counts as
serial here: give the command enough steps that it is small (docs/threads.md, "Past two cores").

    /usr/bin/python3 bench/serial_share.py build/bench/bench_step SCENE --steps 3000 --threads 2
Needs perf (Debian: linux-perf).
"""
import re
import subprocess
import sys
import tempfile

IDLE = re.compile(r"Team::resize|wait_while_equal|sched_yield|pvm_irq_enable|wait_until_at_least|"
                  r"futex|schedule|finish_task_switch|do_syscall|entry_SYSCALL|syscall_exit")


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    with tempfile.NamedTemporaryFile(suffix=".data") as data:
        run = subprocess.run(["perf", "record", "-q", "-e", "cpu-clock", "-F", "1999", "-o",
                              data.name, "--"] + sys.argv[1:], stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True)
        if run.returncode != 0:
            sys.exit(f"serial_share: the command exited with {run.returncode}: {run.stderr[-500:]}")
        report = subprocess.run(["perf", "report", "-i", data.name, "--no-children", "--sort",
                                 "pid,sym", "--stdio", "-F", "overhead,sample,pid,sym"],
                                check=True, capture_output=True, text=True).stdout
    threads = {}
    for line in report.splitlines():
        m = re.match(r"\s*[\d.]+%\s+(\d+)\s+(\d+):\S+\s+\[.\]\s+(.*)", line)
        if not m:
            continue
        samples, tid, sym = int(m.group(1)), int(m.group(2)), m.group(3)
        work, wait = threads.get(tid, (0, 0))
        threads[tid] = (work, wait + samples) if IDLE.search(sym) else (work + samples, wait)
    if len(threads) < 2:
        sys.exit("serial_share: fewer than two threads sampled (run on 2 or more threads)")
    calling = min(threads)  # the first thread of the process
    workers = [t for t in threads if t != calling]
    worker_work = sum(threads[t][0] for t in workers)
    calling_total = sum(threads[calling])
    for t in sorted(threads):
        note = " (calling)" if t == calling else ""
        print(f"thread {t}{note}: {threads[t][0]} samples at work, {threads[t][1]} waiting")
    alone = max(0.0, (calling_total - worker_work / len(workers)) / calling_total)
    print(f"serial share of the calling thread's time: {alone:.3f}")


if __name__ == "__main__":
    main()
