# reports.py: reads back the findings a probe program reported with report.h: (X, Y) at each
# toggle of Z DIR, in order, from the virtual board's trace.
import sys


def read_reports(trace_path):
    rows = [l.strip().split(",") for l in open(trace_path) if not l.startswith("#")][1:]
    events = sorted((int(r[2]), int(r[1]), int(r[3])) for r in rows if r[0] == "dir")
    level = [0, 0]  # X and Y DIR
    reports = []
    for _, motor, value in events:
        if motor == 2:
            reports.append(tuple(level))
        elif motor < 2:
            level[motor] = value
    return reports


def fail(probe, message):
    print(f"{probe} FAILED: {message}")
    sys.exit(1)
