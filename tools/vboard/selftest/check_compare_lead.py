#!/usr/bin/env python3
# check_compare_lead.py: checks the trace of compare_lead.c on the virtual board: which leads of a
# Timer1 compare fire, in which arming order, and that the compare fires on its tick.
import sys

LEADS = [8, 12, 16, 24, 48, 100, 200]  # compare_lead.c's kLeads
TRIALS = 64
ORDERS = ["write then clear", "clear then write"]


def fail(message):
    print("compare-lead FAILED: " + message)
    sys.exit(1)


def main():
    rows = [l.strip().split(",") for l in open(sys.argv[1]) if not l.startswith("#")][1:]
    events = sorted((int(r[2]), r[0], int(r[1])) for r in rows if r[0] in ("step", "dir"))
    trials = []  # (order, ("step" or "dir", cycles from the mark)): a compare or a miss
    order = 0
    for k, (cycle, kind, motor) in enumerate(events):
        if kind == "dir" and motor == 2:  # Z DIR: the next order
            order += 1
        elif kind == "dir" and motor == 1:  # Y DIR: a trial's mark
            outcome = next(((e[1], e[0] - cycle) for e in events[k + 1:k + 4] if e[2] == 0), None)
            trials.append((order, outcome))
    if len(trials) != len(ORDERS) * len(LEADS) * TRIALS:
        fail(f"{len(trials)} trials in the trace, expected {len(ORDERS) * len(LEADS) * TRIALS}")
    offsets = {}
    for o, name in enumerate(ORDERS):
        of_order = [t for t in trials if t[0] == o]
        for i, lead in enumerate(LEADS):
            group = [t[1] for t in of_order[i * TRIALS:(i + 1) * TRIALS]]
            if any(g is None for g in group):
                fail(f"{name}, lead {lead}: a trial with neither a compare nor a miss")
            fired = [g[1] - lead for g in group if g[0] == "step"]
            print(f"  {name}, armed {lead:3} ticks ahead: {len(fired)} of {TRIALS} fired"
                  + (f", raise - mark - lead = {sorted(set(fired))} cycles" if fired else ""))
            # The firmware's order: a compare that matches before the flag is cleared is erased.
            if o == 0 and lead == 8 and fired:
                fail(f"{name}, lead 8: fired ({len(fired)}), expected the clear to erase the match")
            # 16 ticks covers this program's arming: about 15 cycles from the timer read to the clear
            # (its disassembly with Debian's avr-gcc 5.4), the same for every trial
            if lead >= 16 and len(fired) != TRIALS:
                fail(f"{name}, lead {lead}: {TRIALS - len(fired)} of {TRIALS} missed")
            if lead >= 24:
                offsets.setdefault(o, set()).update(fired)
    # On its tick: with the match after the sei, the raise comes a constant time after it.
    for o, values in offsets.items():
        if len(values) != 1:
            fail(f"{ORDERS[o]}: raise - mark - lead varies: {sorted(values)}")
    print("compare-lead passed")


main()
