#!/usr/bin/env python3
# check_uart_rxcie.py: checks the trace of uart_rxcie.c on the virtual board: each byte's receive
# interrupt, turned on while the byte waited, was taken at once (within kPromptCycles), as on
# the chip.
import sys

import reports

MIN_REPORTS = 4  # of the client's 8 bytes (it may start after the board's first few ms)


def fail(message):
    reports.fail("uart-rxcie", message)


def main():
    found = reports.read_reports(sys.argv[1])  # (X, Y) at each toggle of Z DIR
    if len(found) < MIN_REPORTS:
        fail(f"{len(found)} reports in the trace, expected {MIN_REPORTS} or more")
    prompt = sum(1 for x, _ in found if x)
    came = sum(1 for _, y in found if y)
    print(f"  {len(found)} bytes: the receive ISR came for {came}, at once (within uart_rxcie.c's kPromptCycles of RXCIE0) for {prompt}")
    if came != len(found):
        fail("a waiting byte's receive interrupt never came once RXCIE0 was on")
    if prompt != len(found):
        fail("a waiting byte's receive interrupt came late once RXCIE0 was on (simavr 1.6 alone: up to a byte time)")
    print("  as on the chip: turning RXCIE0 on with a byte waiting takes the interrupt at once")
    return 0


if __name__ == "__main__":
    sys.exit(main())
