// link.cpp: termios and libserialport implementations of Link.
#include "board/link.h"

#include <fcntl.h>
#include <libserialport.h>
#include <linux/serial.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include "stepchoir_protocol.h"

namespace stepchoir {
namespace {

// A pseudo-terminal or a tty opened with POSIX calls.
class TermiosLink : public Link {
 public:
  explicit TermiosLink(const std::string &path) : path_(path) {
    fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) throw std::runtime_error(path + ": cannot open: " + std::strerror(errno));
    termios t{};
    if (tcgetattr(fd_, &t) != 0) {
      ::close(fd_);
      throw std::runtime_error(path + ": not a terminal: " + std::strerror(errno));
    }
    cfmakeraw(&t);
    t.c_cflag |= CLOCAL | CREAD;
    cfsetispeed(&t, B1000000);
    cfsetospeed(&t, B1000000);
    t.c_cc[VMIN] = 0;
    t.c_cc[VTIME] = 0;
    tcsetattr(fd_, TCSANOW, &t);
    tcflush(fd_, TCIOFLUSH);  // bytes from before the open are stale (a reset board says hello anew)
  }
  ~TermiosLink() override { ::close(fd_); }

  bool write(const uint8_t *data, size_t len) override {
    while (len > 0) {
      const ssize_t n = ::write(fd_, data, len);
      if (n > 0) {
        data += n;
        len -= static_cast<size_t>(n);
      } else if (n < 0 && (errno == EAGAIN || errno == EINTR)) {
        pollfd p{fd_, POLLOUT, 0};
        ::poll(&p, 1, 100);
      } else {
        return false;
      }
    }
    return true;
  }

  bool try_write(const uint8_t *data, size_t len) override {
    const ssize_t n = ::write(fd_, data, len);  // the descriptor does not block
    if (n <= 0) return false;
    return static_cast<size_t>(n) == len || write(data + n, len - static_cast<size_t>(n));  // rare: a full buffer
  }

  long read(uint8_t *data, size_t len, int timeout_ms) override {
    pollfd p{fd_, POLLIN, 0};
    const int r = ::poll(&p, 1, timeout_ms);
    if (r < 0) return errno == EINTR ? 0 : -1;
    if (r == 0) return 0;
    if (p.revents & (POLLERR | POLLNVAL)) return -1;
    const ssize_t n = ::read(fd_, data, len);
    if (n < 0) return (errno == EAGAIN || errno == EINTR) ? 0 : -1;
    if (n == 0 && (p.revents & POLLHUP)) return -1;
    return n;
  }

  std::string name() const override { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
};

// A real serial port through libserialport.
class SerialLink : public Link {
 public:
  explicit SerialLink(const std::string &path) : path_(path) {
    if (sp_get_port_by_name(path.c_str(), &port_) != SP_OK)
      throw std::runtime_error(path + ": no such serial port");
    if (sp_open(port_, SP_MODE_READ_WRITE) != SP_OK) {
      std::string why = sp_last_error_message();
      sp_free_port(port_);
      throw std::runtime_error(path + ": cannot open: " + why);
    }
    sp_set_baudrate(port_, static_cast<int>(sc::kBaud));
    sp_set_bits(port_, 8);
    sp_set_parity(port_, SP_PARITY_NONE);
    sp_set_stopbits(port_, 1);
    sp_set_flowcontrol(port_, SP_FLOWCONTROL_NONE);
    sp_flush(port_, SP_BUF_BOTH);  // bytes from before the open are stale (a reset board says hello anew)
    int fd = -1;  // the driver's low-latency flag, where it has one
    if (sp_get_port_handle(port_, &fd) == SP_OK && fd >= 0) set_low_latency(fd);
  }
  ~SerialLink() override {
    sp_close(port_);
    sp_free_port(port_);
  }

  bool write(const uint8_t *data, size_t len) override {
    return sp_blocking_write(port_, data, len, 1000) == static_cast<int>(len);
  }
  bool try_write(const uint8_t *data, size_t len) override {
    if (sp_output_waiting(port_) != 0) return false;  // bytes queued, or an error
    const int n = sp_nonblocking_write(port_, data, len);
    if (n <= 0) return false;
    return static_cast<size_t>(n) == len || write(data + n, len - static_cast<size_t>(n));  // rare: a full buffer
  }

  long read(uint8_t *data, size_t len, int timeout_ms) override {
    const int n = sp_blocking_read_next(port_, data, len, static_cast<unsigned>(timeout_ms));
    return n < 0 ? -1 : n;
  }

  std::string name() const override { return path_; }

 private:
  std::string path_;
  sp_port *port_ = nullptr;
};

// True when path names a pseudo-terminal, directly or through symlinks.
bool is_pty(const std::string &path) {
  char real[PATH_MAX];
  if (!::realpath(path.c_str(), real)) return false;
  return std::strncmp(real, "/dev/pts/", 9) == 0;
}

}  // namespace

bool set_low_latency(int fd) {
  serial_struct serial{};
  if (ioctl(fd, TIOCGSERIAL, &serial) != 0) return false;
  if (!(serial.flags & ASYNC_LOW_LATENCY)) {
    serial.flags |= ASYNC_LOW_LATENCY;
    if (ioctl(fd, TIOCSSERIAL, &serial) != 0) return false;
    if (ioctl(fd, TIOCGSERIAL, &serial) != 0) return false;
  }
  return (serial.flags & ASYNC_LOW_LATENCY) != 0;
}

std::unique_ptr<Link> open_link(const std::string &path) {
  if (is_pty(path)) return std::make_unique<TermiosLink>(path);
  return std::make_unique<SerialLink>(path);
}

std::vector<std::string> list_serial_ports() {
  std::vector<std::string> out;
  sp_port **ports = nullptr;
  if (sp_list_ports(&ports) != SP_OK) return out;
  for (int i = 0; ports[i]; ++i) {
    const char *desc = sp_get_port_description(ports[i]);
    out.push_back(std::string(sp_get_port_name(ports[i])) + "  " + (desc ? desc : ""));
  }
  sp_free_port_list(ports);
  return out;
}

}  // namespace stepchoir
