#!/usr/bin/env python3
"""isr_fingerprint.py: each ISR and step-path function of a firmware ELF, with its size, its
instruction count and a hash of its code with addresses taken out, so that two builds can be
compared function by function (a restructure that must leave the AVR output unchanged).

Usage: isr_fingerprint.py ELF [ELF ...]   (prints one line a function: name bytes insns hash)
       isr_fingerprint.py --diff A.txt B.txt  (the functions whose code differs)
Called by hand and by tools/firmware/compare-isr.sh; reads avr-objdump and avr-nm output."""
import hashlib
import re
import subprocess
import sys

# The functions whose cycles bind: every interrupt vector, the motors' handlers and what they
# call, the main loop's channel operations.
KEEP = re.compile(r"__vector|serve|arm|poke|busy|command|apply|account|deadline|sched|link|drivers|now")


def functions(elf):
    out = subprocess.run(["avr-nm", "-S", "--size-sort", "-C", elf], check=True, capture_output=True, text=True).stdout
    raw = subprocess.run(["avr-nm", "-S", "--size-sort", elf], check=True, capture_output=True, text=True).stdout
    names = {}
    for demangled, mangled in zip(out.splitlines(), raw.splitlines()):
        parts = mangled.split()
        if len(parts) < 4 or parts[2] not in "TtWw":
            continue
        names[parts[3]] = (int(parts[0], 16), int(parts[1], 16), demangled.split(None, 3)[3])
    return names


def disassemble(elf):
    text = subprocess.run(["avr-objdump", "-d", "--no-show-raw-insn", elf], check=True, capture_output=True, text=True).stdout
    insns = {}
    for line in text.splitlines():
        m = re.match(r"\s+([0-9a-f]+):\s+(\S.*)$", line)
        if m:
            insns[int(m.group(1), 16)] = m.group(2)
    return insns


IO_OPS = ("sbi", "cbi", "sbic", "sbis", "in", "out")


def normalize(insn):
    insn = insn.split(";")[0].strip()
    # Branch offsets, call targets and RAM addresses change with layout: they become '#'. I/O
    # register numbers (sbi, cbi, sbic, sbis, in, out) are fixed by the chip and kept.
    if insn.split()[0] in IO_OPS:
        return insn
    return re.sub(r"(\.[+-]\d+|0x[0-9a-fA-F]+)", "#", insn)


def fingerprint(elf):
    names = functions(elf)
    insns = disassemble(elf)
    rows = []
    for mangled, (addr, size, pretty) in sorted(names.items(), key=lambda kv: kv[1][2]):
        if not KEEP.search(mangled):
            continue
        code = [normalize(insns[a]) for a in sorted(insns) if addr <= a < addr + size]
        digest = hashlib.sha1("\n".join(code).encode()).hexdigest()[:12]
        rows.append((pretty.replace(" ", ""), size, len(code), digest))
    return rows


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "--diff":
        a = dict((l.split()[0], l.split()[1:]) for l in open(sys.argv[2]) if l.strip())
        b = dict((l.split()[0], l.split()[1:]) for l in open(sys.argv[3]) if l.strip())
        same = 0
        for k in sorted(set(a) | set(b)):
            if a.get(k) == b.get(k):
                same += 1
            else:
                print(f"{k}: {' '.join(a.get(k, ['-']))}  ->  {' '.join(b.get(k, ['-']))}")
        print(f"{same} functions the same")
        return
    for elf in sys.argv[1:]:
        for name, size, n, digest in fingerprint(elf):
            print(f"{name} {size} {n} {digest}")


if __name__ == "__main__":
    main()
