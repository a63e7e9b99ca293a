#!/usr/bin/env python3
# uart_rxcie_client.py PTY: sends uart_rxcie.c its bytes through the virtual board's pty, one
# every 20 ms (each is one measurement).
import os
import sys
import termios
import time
import tty

BYTES = 8


def main():
    fd = os.open(sys.argv[1], os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    termios.tcflush(fd, termios.TCIOFLUSH)
    for i in range(BYTES):
        os.write(fd, bytes([0x41 + i]))
        time.sleep(0.02)
    os.close(fd)
    return 0


if __name__ == "__main__":
    sys.exit(main())
