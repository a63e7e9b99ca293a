// link.h: a byte pipe to a board: real serial ports through libserialport, pseudo-terminals
// (the virtual board) through POSIX termios, behind one interface.
#ifndef STEPCHOIR_HOST_LINK_H
#define STEPCHOIR_HOST_LINK_H

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace stepchoir {

class Link {
 public:
  virtual ~Link() = default;
  // Called from: the writer thread. Writes all bytes; false when the port failed.
  virtual bool write(const uint8_t *data, size_t len) = 0;
  // Called from: the live engine thread. Writes all bytes at once when the OS takes them without
  // waiting (nothing queued ahead of them); otherwise writes nothing and returns false, as it
  // does on a link that cannot tell. Never blocks for long.
  virtual bool try_write(const uint8_t *, size_t) { return false; }
  // Called from: the reader thread. Reads up to len bytes, waiting up to timeout_ms;
  // returns the count (0 on timeout) or -1 when the port failed.
  virtual long read(uint8_t *data, size_t len, int timeout_ms) = 0;
  // What was opened, for messages.
  virtual std::string name() const = 0;
  // For a link whose write() only queues the bytes (jam's JamLink: the live writer sends them
  // later): waits until the last write() reached the OS and returns when it did (monotonic_us);
  // 0 when write() itself hands the bytes to the OS (every port) or it did not happen in time.
  // Called from: the song player, after a clock request's write (its true send time).
  virtual uint64_t written_at_us() { return 0; }
  // True for a link whose write() only queues (written_at_us then tells the send time).
  virtual bool queues_writes() const { return false; }
};

// Opens a board at `path` at the protocol's baud rate, raw 8N1. Pseudo-terminals (and links
// to them) use termios, since libserialport refuses them; anything else uses libserialport.
// Throws std::runtime_error with the path and the reason.
std::unique_ptr<Link> open_link(const std::string &path);

// Asks the serial driver behind fd to pass received bytes on at once (ASYNC_LOW_LATENCY: an
// FTDI bridge's latency timer goes from 16 ms to 1 ms). True when the driver has the flag
// afterwards; false when it has no such flag (a pseudo-terminal, a driver without it), which is
// harmless. Called from: open_link, on a serial port just opened.
bool set_low_latency(int fd);

// Serial ports libserialport can see, as "path  description".
std::vector<std::string> list_serial_ports();

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LINK_H
