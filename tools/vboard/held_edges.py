#!/usr/bin/env python3
"""held_edges.py: what held a motor's late STEP edges up, from a virtual board run.

Usage: held_edges.py ELF TRACE.csv IOFFLOG MOTOR PERIOD_CYCLES [MIN_LATE_CYCLES]

TRACE.csv is the board's --trace; IOFFLOG is the file STEPCHOIR_VBOARD_IOFFLOG wrote in the same
run (every interrupts-off window: start cycle, start address, length). For each steady stretch
of MOTOR's edges at about PERIOD_CYCLES (within 1 %), the edges are fitted to a straight grid;
an edge later than the stretch's 5th-percentile residual by MIN_LATE_CYCLES (default 20) or more
is listed with the interrupts-off windows that overlapped its wait (from the grid time, less the
stub's 16 cycles to the raise, to its raise), each as +offset:where(length): `vecN` is the entry
of interrupt vector N (its stub or ISR), else the function and offset it started in. A count of
where the windows started ends the list.

Example (Uno, the full-speed pitch test, motor 1 on MIDI 57):
  STEPCHOIR_VBOARD_IOFFLOG=/tmp/ioff.txt build/bin/test_e2e "uno: every motor in tune across MIDI 24-108 - frames at full speed"
  tools/vboard/held_edges.py build/firmware/stepchoir-uno.elf build/e2e/pitch-uno.csv /tmp/ioff.txt 1 72727
"""
import bisect
import collections
import subprocess
import sys

# Cycles from a match to its stub's raise: 13 by the instruction count, and up to 3 more while
# the instruction the match fell in finishes.
STUB_TO_RAISE = 16


def symbols(elf):
    out = subprocess.run(["avr-nm", "-C", "-S", elf], capture_output=True, text=True, check=True).stdout
    syms = []
    for line in out.splitlines():
        p = line.split(None, 3)
        if len(p) == 4 and p[2] in "tTwW":
            syms.append((int(p[0], 16), int(p[1], 16), p[3]))
    return sorted(syms)


def main():
    if len(sys.argv) < 6:
        print(__doc__)
        return 2
    elf, trace, ioff_log, motor, period = sys.argv[1:6]
    motor, period = int(motor), float(period)
    min_late = int(sys.argv[6]) if len(sys.argv) > 6 else 20
    syms = symbols(elf)
    starts = [s[0] for s in syms]
    arch = subprocess.run(["avr-objdump", "-f", elf], capture_output=True, text=True, check=True).stdout
    vectors = 57 if "avr:6" in arch else 26  # ATmega2560, else ATmega328P; a jmp (4 bytes) each

    def where(address):
        if address < vectors * 4 and address % 4 == 0:
            return f"vec{address // 4}"
        i = bisect.bisect_right(starts, address) - 1
        if i >= 0 and address < syms[i][0] + syms[i][1]:
            return f"{syms[i][2][:30]}+{address - syms[i][0]:x}"
        return hex(address)

    edges = [int(l.split(",")[2]) for l in open(trace) if l.startswith(f"step,{motor},")]
    gaps = [b - a for a, b in zip(edges, edges[1:])]
    stretches = []
    i = 0
    while i < len(gaps):
        j = i
        while j + 1 < len(gaps) and abs(gaps[j + 1] - gaps[i]) < 0.01 * gaps[i]:
            j += 1
        if abs(gaps[i] - period) < 0.01 * period and j - i > 50:
            stretches.append(edges[i + 3:j + 2])  # the first edges of a note may ramp
        i = j + 1
    windows = sorted(tuple(int(v, 16) if k == 1 else int(v) for k, v in enumerate(l.split())) for l in open(ioff_log))
    window_starts = [w[0] for w in windows]
    held_by = collections.Counter()
    late = 0
    for x in stretches:
        n = len(x)
        mk, mx = (n - 1) / 2, sum(x) / n
        slope = sum((k - mk) * (v - mx) for k, v in enumerate(x)) / sum((k - mk) ** 2 for k in range(n))
        residual = [v - (mx + slope * (k - mk)) for k, v in enumerate(x)]
        base = sorted(residual)[len(residual) // 20]
        for t, r in zip(x, residual):
            wait = r - base
            if wait < min_late:
                continue
            late += 1
            lo, hi = t - int(wait) - STUB_TO_RAISE, t - 2
            a = bisect.bisect_left(window_starts, lo - 200)
            held = []
            while a < len(windows) and windows[a][0] < hi:
                start, address, length = windows[a]
                if start + length > lo:
                    held.append((start - lo, where(address), length))
                a += 1
            print(f"{wait:.0f} cycles late at cycle {t}: " + " ".join(f"{o:+d}:{w}({n})" for o, w, n in held))
            for _, w, _ in held:
                held_by[w] += 1
    print(f"{late} late edges in {len(stretches)} stretches; windows by where they started: {held_by.most_common(12)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
