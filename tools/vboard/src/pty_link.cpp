// pty_link.cpp: pseudo-terminal creation, raw mode, non-blocking byte transfer and the symlink.
#include "pty_link.h"

#include <fcntl.h>
#include <sys/inotify.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace vboard {

// Closes the pty and removes the link.
PtyLink::~PtyLink() {
  remove_link();
  if (inotify_fd_ >= 0) ::close(inotify_fd_);
  if (slave_fd_ >= 0) ::close(slave_fd_);
  if (master_fd_ >= 0) ::close(master_fd_);
}

// Creates the pty (raw, non-blocking master).
bool PtyLink::open(std::string &error) {
  master_fd_ = posix_openpt(O_RDWR | O_NOCTTY);
  if (master_fd_ < 0 || grantpt(master_fd_) != 0 || unlockpt(master_fd_) != 0) {
    error = std::string("cannot create a pseudo-terminal: ") + std::strerror(errno);
    return false;
  }
  const char *name = ptsname(master_fd_);
  if (!name) {
    error = std::string("ptsname failed: ") + std::strerror(errno);
    return false;
  }
  slave_path_ = name;
  slave_fd_ = ::open(name, O_RDWR | O_NOCTTY);
  if (slave_fd_ < 0) {
    error = "cannot open " + slave_path_ + ": " + std::strerror(errno);
    return false;
  }
  termios tio;
  if (tcgetattr(slave_fd_, &tio) != 0) {
    error = std::string("tcgetattr failed: ") + std::strerror(errno);
    return false;
  }
  cfmakeraw(&tio);  // 8 bits, no echo, no CR/LF mapping, no XON/XOFF
  cfsetispeed(&tio, B1000000);
  cfsetospeed(&tio, B1000000);
  if (tcsetattr(slave_fd_, TCSANOW, &tio) != 0) {
    error = std::string("tcsetattr failed: ") + std::strerror(errno);
    return false;
  }
  // Opens of the slave from now on are the host's (ours came before the watch).
  inotify_fd_ = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
  if (inotify_fd_ < 0 || inotify_add_watch(inotify_fd_, slave_path_.c_str(), IN_OPEN | IN_CLOSE) < 0) {
    error = std::string("cannot watch the pty for opens: ") + std::strerror(errno);
    return false;
  }
  const int flags = fcntl(master_fd_, F_GETFL);
  if (flags < 0 || fcntl(master_fd_, F_SETFL, flags | O_NONBLOCK) != 0) {
    error = std::string("cannot make the pty non-blocking: ") + std::strerror(errno);
    return false;
  }
  return true;
}

// Makes link_path a symlink to the slave (replacing an existing symlink, never a file).
bool PtyLink::make_link(const std::string &link_path, std::string &error) {
  struct stat st;
  if (lstat(link_path.c_str(), &st) == 0) {
    if (!S_ISLNK(st.st_mode)) {
      error = link_path + " exists and is not a symlink; not replacing it";
      return false;
    }
    if (unlink(link_path.c_str()) != 0) {
      error = "cannot remove old link " + link_path + ": " + std::strerror(errno);
      return false;
    }
  }
  if (symlink(slave_path_.c_str(), link_path.c_str()) != 0) {
    error = "cannot create link " + link_path + ": " + std::strerror(errno);
    return false;
  }
  link_path_ = link_path;
  return true;
}

// Removes the symlink if it still points at our slave.
void PtyLink::remove_link() {
  if (link_path_.empty()) return;
  char target[4096];
  const ssize_t len = readlink(link_path_.c_str(), target, sizeof target - 1);
  if (len > 0) {
    target[len] = '\0';
    if (slave_path_ == target) unlink(link_path_.c_str());
  }
  link_path_.clear();
}

bool PtyLink::take_host_open() {
  bool opened = false;
  alignas(inotify_event) char buffer[4096];
  for (;;) {
    const ssize_t count = ::read(inotify_fd_, buffer, sizeof buffer);
    if (count <= 0) return opened;  // EAGAIN: no more events
    for (ssize_t at = 0; at < count;) {
      const inotify_event *event = reinterpret_cast<const inotify_event *>(buffer + at);
      if ((event->mask & IN_OPEN) && host_opens_++ == 0) opened = true;
      if ((event->mask & IN_CLOSE) && host_opens_ > 0) --host_opens_;
      at += static_cast<ssize_t>(sizeof(inotify_event) + event->len);
    }
  }
}

// Reads what the host wrote into the receive queue, as arrived at host time arrival_ns.
void PtyLink::poll_rx(uint64_t arrival_ns) {
  uint8_t buffer[4096];
  while (bridge_.host_bytes_waiting() < kRxQueueMax) {
    const ssize_t count = ::read(master_fd_, buffer, sizeof buffer);
    if (count > 0) {
      bridge_.from_host(buffer, static_cast<size_t>(count), arrival_ns);
      rx_bytes_ += static_cast<uint64_t>(count);
      if (static_cast<size_t>(count) < sizeof buffer) return;
      continue;
    }
    if (count < 0 && errno == EINTR) continue;
    return;  // EAGAIN: nothing more; EIO: no host side open (cannot happen while we hold one)
  }
}

// Takes the next received byte.
uint8_t PtyLink::rx_pop() { return bridge_.board_byte_pop(); }

// Queues one byte the AVR sent at host time now_ns; drops it when the queue is full (the loop
// flushes every chunk, so the queue only fills when nobody reads the pty).
void PtyLink::tx_push(uint8_t byte, uint64_t now_ns) {
  if (tx_queue_.size() + bridge_.board_bytes_waiting() >= kTxQueueMax) {
    ++tx_dropped_;
    return;
  }
  bridge_.from_board(byte, now_ns);
}

// Writes the bytes the bridge has passed by now to the host, as far as the pty accepts them.
size_t PtyLink::flush_tx() {
  const size_t held = tx_queue_.size();
  bridge_.to_host(now_ns_, tx_queue_);
  const size_t passed = tx_queue_.size() - held;
  size_t consumed = 0;
  while (consumed < tx_queue_.size()) {
    const ssize_t count = ::write(master_fd_, tx_queue_.data() + consumed, tx_queue_.size() - consumed);
    if (count > 0) {
      consumed += static_cast<size_t>(count);
      tx_bytes_ += static_cast<uint64_t>(count);
      continue;
    }
    if (count < 0 && errno == EINTR) continue;
    if (count < 0 && errno == EIO) {  // host side gone: nobody will read these
      tx_dropped_ += tx_queue_.size() - consumed;
      consumed = tx_queue_.size();
    }
    break;  // EAGAIN: the pty is full, keep the rest for later
  }
  tx_queue_.erase(tx_queue_.begin(), tx_queue_.begin() + static_cast<std::ptrdiff_t>(consumed));
  return passed;
}

}  // namespace vboard
