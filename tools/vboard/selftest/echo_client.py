#!/usr/bin/env python3
# echo_client.py: sends bytes 0..255 through the vboard pty and checks each comes back +1, twice.
import os
import select
import sys
import termios
import time
import tty


def main():
    path = sys.argv[1]
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    termios.tcflush(fd, termios.TCIOFLUSH)
    sent = bytes(range(256))
    expected = b"".join(bytes([(b + 1) & 0xFF]) * 2 for b in sent)
    os.write(fd, sent)
    received = b""
    deadline = time.monotonic() + 5.0
    while len(received) < len(expected) and time.monotonic() < deadline:
        ready, _, _ = select.select([fd], [], [], 0.1)
        if ready:
            received += os.read(fd, 4096)
    os.close(fd)
    if received != expected:
        first_bad = next((i for i in range(min(len(received), len(expected)))
                          if received[i] != expected[i]), min(len(received), len(expected)))
        print(f"echo FAILED: got {len(received)} of {len(expected)} bytes, first mismatch at {first_bad}")
        return 1
    print(f"echo ok: {len(sent)} bytes sent, {len(received)} bytes back")
    return 0


if __name__ == "__main__":
    sys.exit(main())
