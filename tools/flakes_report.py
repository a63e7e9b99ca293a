#!/usr/bin/env python3
"""flakes_report.py TMPDIR RUNS_DONE RUNS_ASKED OUT START: writes the flake report (Markdown)
from what tools/flakes.sh collected in TMPDIR: all.txt and pacing.txt (test names, from
`ctest -N`), results.txt ("Passed NAME" / "Failed NAME" a line, every run), stalls.txt (per run,
how often the virtual board said the machine stalled it). Called by tools/flakes.sh after each
run, so that an interrupted hunt still leaves its report."""
import collections
import pathlib
import sys


def main():
    tmp, done, asked, out, start = pathlib.Path(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
    pacing = {n for n in (tmp / "pacing.txt").read_text().split("\n") if n}
    names = [n for n in (tmp / "all.txt").read_text().split("\n") if n]
    seen, failed = collections.Counter(), collections.Counter()
    for line in (tmp / "results.txt").read_text().split("\n"):
        if not line:
            continue
        verdict, name = line.split(" ", 1)
        seen[name] += 1
        if verdict != "Passed":
            failed[name] += 1
    stalls = sum(int(x) for x in (tmp / "stalls.txt").read_text().split() if x.strip())
    over = [n for n in names if failed[n] > (1 if n in pacing else 0)]
    with open(out, "w") as f:
        f.write("# End-to-end tests: failures in repeated runs\n\n")
        f.write(f"Command: `tools/flakes.sh {asked}` (each run: `ctest -L e2e` in build/, the machine otherwise idle).\n\n")
        f.write(f"Started {start}; {len(names)} tests; {done} of {asked} runs done.\n\n")
        f.write("Target: 0 failures for a test without the `pacing` label, at most 1 for a test with it. ")
        f.write(f"Tests over it: {len(over)}. Failed runs whose output says the virtual board was stalled by the machine: {stalls}.\n\n")
        f.write("| test | pacing | runs | failed |\n|---|---|---|---|\n")
        for n in sorted(names, key=lambda n: (-failed[n], n)):
            f.write(f"| {n} | {'yes' if n in pacing else ''} | {seen[n]} | {failed[n]} |\n")
    print(f"flakes: wrote {out} ({done} of {asked} runs): {len(over)} tests over target")


if __name__ == "__main__":
    main()
