#!/usr/bin/env python3
# check_trace.py: checks a selftest trace: step count and spacing to the cycle, switch, UART pacing.
import sys

STEP_PERIOD_CYCLES = 1600


def fail(message):
    print("trace FAILED: " + message)
    sys.exit(1)


def main():
    path, travel, start = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    lines = open(path).read().splitlines()
    if not lines[0].startswith("# stepchoir-vboard trace v1 board=uno f_cpu=16000000 clock_ppm=0 motors=4"):
        fail("bad first line: " + lines[0])
    if lines[1] != "event,motor,cycle,value,position,width":
        fail("bad header: " + lines[1])
    rows = [l.split(",") for l in lines[2:] if not l.startswith("#")]
    comments = [l for l in lines if l.startswith("#")]
    end_cycle = next(int(l.split("=")[1]) for l in comments if l.startswith("# end cycle="))
    summary = "\n".join(l for l in comments if l.startswith("# summary"))

    tx_marks = [int(r[2]) for r in rows if r[0] == "dir" and r[1] == "2"]
    if len(tx_marks) != 512:
        fail(f"{len(tx_marks)} UART writes marked, expected 512")
    uart_window = (tx_marks[0] - 2 * STEP_PERIOD_CYCLES, tx_marks[-1] + 2 * STEP_PERIOD_CYCLES)

    steps = [r for r in rows if r[0] == "step" and r[1] == "0"]
    rises = [int(r[2]) for r in steps]
    if not rises:
        fail("no X steps")
    # Timer1 runs off the exact clock: pulse k rises at first + k*1600 plus the interrupt latency,
    # which is constant while the UART is quiet (the core sleeps) and a little longer while the
    # UART interrupt is busy.
    quiet_lates, busy_lates = set(), []
    for k, rise in enumerate(rises):
        late = rise - rises[0] - k * STEP_PERIOD_CYCLES
        if uart_window[0] <= rise <= uart_window[1]:
            busy_lates.append(late)
        else:
            quiet_lates.add(late)
    if quiet_lates != {0}:
        fail(f"step timing off by {sorted(quiet_lates)[:5]} cycles outside UART activity")
    if any(not 0 <= late < 800 for late in busy_lates):
        fail(f"step latency during UART activity: {sorted(set(busy_lates))[-5:]}")
    widths = {int(r[5]) for r in steps}
    if len(widths) != 1:
        fail(f"step high time varies: {sorted(widths)}")
    # every pulse that both rose and fell before the end is in the trace
    width = widths.pop()
    expected = (end_cycle - width - rises[0]) // STEP_PERIOD_CYCLES + 1
    if len(rises) != expected:
        fail(f"{len(rises)} steps, expected {expected}")
    if any(r[3] != "1" for r in steps):
        fail("DIR not high at a step")
    positions = [int(r[4]) for r in steps]
    if positions != list(range(start + 1, start + 1 + len(steps))):
        fail("positions do not count up by one")

    endstops = [r for r in rows if r[0] == "endstop" and r[1] == "0"]
    if not endstops or endstops[0][3] != "1" or int(endstops[0][4]) != travel:
        fail(f"no max switch press at position {travel}: {endstops[:2]}")
    press_cycle = int(endstops[0][2])
    mirror = [r for r in rows if r[0] == "dir" and r[1] == "1" and int(r[2]) >= press_cycle]
    if not mirror or mirror[0][3] != "0" or mirror[-1][3] != "0":
        fail("firmware did not see the switch (Y DIR mirror not low at the end)")
    latency = int(mirror[0][2]) - press_cycle
    if not 0 <= latency <= STEP_PERIOD_CYCLES + 100:
        fail(f"switch mirror latency {latency} cycles")
    bounces = [r for r in rows if r[0] == "bounce" and r[1] == "0"]
    if len(bounces) not in (2, 4, 6):
        fail(f"{len(bounces)} bounce rows, expected 2, 4 or 6")
    overshoot_expected = start + len(steps) - travel
    if f"overshoot={overshoot_expected}" not in summary.split("\n")[0]:
        fail("overshoot in summary: " + summary.split("\n")[0])

    enables = [r for r in rows if r[0] == "enable"]
    if sorted(r[1] for r in enables) != ["0", "1", "2", "3"] or any(r[3] != "0" for r in enables):
        fail(f"enable rows: {enables}")

    # The echo is transmit-bound: after the first byte, UDR0 is refilled as soon as the shift
    # register takes a byte, so writes come one byte time (10 bits at 1 Mbaud = 160 cycles) apart
    # on average (each a few cycles late, depending on where the polling loop was).
    mean_gap = (tx_marks[-1] - tx_marks[1]) / (len(tx_marks) - 2)
    if abs(mean_gap - 160) > 1:
        fail(f"UART transmit spacing {mean_gap:.2f} cycles, expected 160")
    isr = next((l for l in comments if "isr=__vector_11 " in l), "")
    if f"entries={len(steps)}" not in isr and f"entries={len(steps) + 1}" not in isr:
        fail("TIMER1_COMPA entries do not match the steps: " + isr)
    print(f"trace ok: {len(steps)} steps every {STEP_PERIOD_CYCLES} cycles (max latency during UART "
          f"traffic {max(busy_lates, default=0)}), high {width} cycles, "
          f"{len(bounces)} bounces, switch seen after {latency} cycles, UART spacing {mean_gap:.2f} cycles")
    return 0


if __name__ == "__main__":
    sys.exit(main())
