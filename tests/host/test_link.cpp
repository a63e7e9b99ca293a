// test_link.cpp: the serial driver's low-latency flag (board/link.h set_low_latency): a real
// port opened by open_link gets it; a pseudo-terminal, which has no such flag, is left working.
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <linux/serial.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

#include "board/link.h"

using namespace stepchoir;

namespace {

// The driver's flags of the port at fd; false when it has none (not a serial driver).
bool serial_flags(int fd, int *flags) {
  serial_struct s{};
  if (ioctl(fd, TIOCGSERIAL, &s) != 0) return false;
  *flags = s.flags;
  return true;
}

bool set_serial_flags(int fd, int flags) {
  serial_struct s{};
  if (ioctl(fd, TIOCGSERIAL, &s) != 0) return false;
  s.flags = flags;
  return ioctl(fd, TIOCSSERIAL, &s) == 0;
}

}  // namespace

TEST_CASE("link: a pseudo-terminal has no low-latency flag, and asking for it leaves the link working", "[link]") {
  const int master = ::posix_openpt(O_RDWR | O_NOCTTY);
  REQUIRE(master >= 0);
  REQUIRE(::grantpt(master) == 0);
  REQUIRE(::unlockpt(master) == 0);
  const std::string path = ::ptsname(master);
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY);
  REQUIRE(fd >= 0);
  CHECK_FALSE(set_low_latency(fd));
  ::close(fd);
  std::unique_ptr<Link> link = open_link(path);  // termios, no flag asked; the pty carries bytes
  const uint8_t out[3] = {1, 2, 3};
  CHECK(link->write(out, sizeof out));
  uint8_t in[8] = {};
  CHECK(::read(master, in, sizeof in) == 3);
  ::close(master);
}

// A real serial driver: the machine's first 8250 UART (/dev/ttyS0), which a virtual machine
// has. Its flag cleared, opened as a board's port: open_link sets it again. The port's line
// settings and flags are put back as they were.
TEST_CASE("link: a serial port opened for a board gets the driver's low-latency flag", "[link]") {
  const int fd = ::open("/dev/ttyS0", O_RDWR | O_NOCTTY | O_NONBLOCK);
  int before = 0;
  if (fd < 0 || !serial_flags(fd, &before)) {
    WARN("no serial driver at /dev/ttyS0 on this machine: the flag is not checked here");
    if (fd >= 0) ::close(fd);
    return;
  }
  termios line{};
  const bool have_line = tcgetattr(fd, &line) == 0;
  struct Restore {
    int fd, flags;
    bool have_line;
    termios line;
    ~Restore() {
      if (have_line) tcsetattr(fd, TCSANOW, &line);
      set_serial_flags(fd, flags);
      ::close(fd);
    }
  } restore{fd, before, have_line, line};
  REQUIRE(set_serial_flags(fd, before & ~ASYNC_LOW_LATENCY));
  int flags = 0;
  REQUIRE(serial_flags(fd, &flags));
  REQUIRE_FALSE(flags & ASYNC_LOW_LATENCY);
  {
    std::unique_ptr<Link> link = open_link("/dev/ttyS0");
    REQUIRE(serial_flags(fd, &flags));
    CHECK(flags & ASYNC_LOW_LATENCY);
  }
  REQUIRE(set_serial_flags(fd, before & ~ASYNC_LOW_LATENCY));
  CHECK(set_low_latency(fd));  // the call itself, on the descriptor
  REQUIRE(serial_flags(fd, &flags));
  CHECK(flags & ASYNC_LOW_LATENCY);
}
