#!/usr/bin/env python3
# check_uart_rxcie.py: checks the trace of uart_rxcie.c on the virtual board: each byte's receive
# interrupt, turned on while the byte waited, was taken at once (within kPromptCycles), as on
# the chip.
import sys

MIN_REPORTS = 4  # of the client's 8 bytes (it may start after the board's first few ms)


def fail(message):
    print("uart-rxcie FAILED: " + message)
    sys.exit(1)


def main():
    rows = [l.strip().split(",") for l in open(sys.argv[1]) if not l.startswith("#")][1:]
    events = sorted((int(r[2]), int(r[1]), int(r[3])) for r in rows if r[0] == "dir")
    level = [0, 0]  # X and Y DIR
    reports = []  # (X, Y) at each toggle of Z DIR
    for _, motor, value in events:
        if motor == 2:
            reports.append(tuple(level))
        elif motor < 2:
            level[motor] = value
    if len(reports) < MIN_REPORTS:
        fail(f"{len(reports)} reports in the trace, expected {MIN_REPORTS} or more")
    prompt = sum(1 for x, _ in reports if x)
    came = sum(1 for _, y in reports if y)
    print(f"  {len(reports)} bytes: the receive ISR came for {came}, at once (within 60 cycles of RXCIE0) for {prompt}")
    if came != len(reports):
        fail("a waiting byte's receive interrupt never came once RXCIE0 was on")
    if prompt != len(reports):
        fail("a waiting byte's receive interrupt came late once RXCIE0 was on (simavr 1.6 alone: up to a byte time)")
    print("  as on the chip: turning RXCIE0 on with a byte waiting takes the interrupt at once")
    return 0


if __name__ == "__main__":
    sys.exit(main())
