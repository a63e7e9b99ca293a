// pty_link.h: the board's serial port as a pseudo-terminal, with byte queues both ways (POSIX).
#ifndef STEPCHOIR_VBOARD_PTY_LINK_H
#define STEPCHOIR_VBOARD_PTY_LINK_H

#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

namespace vboard {

// Owns a raw pty pair. The host opens slave_path(); the simulator loop calls poll_rx() and
// flush_tx() without ever blocking. A slave fd stays open here so the pty does not hang up
// when the host closes it. Bytes for a host that does not read are buffered up to a limit,
// then dropped and counted.
class PtyLink {
 public:
  PtyLink() = default;
  PtyLink(const PtyLink &) = delete;
  PtyLink &operator=(const PtyLink &) = delete;
  // Closes the pty and removes the link.
  ~PtyLink();

  // Creates the pty (raw, non-blocking master); on failure fills error.
  bool open(std::string &error);
  // Path the host opens, e.g. /dev/pts/3.
  const std::string &slave_path() const { return slave_path_; }
  // Makes link_path a symlink to the slave (replacing an existing symlink).
  bool make_link(const std::string &link_path, std::string &error);
  // Removes the symlink if it still points at our slave.
  void remove_link();

  // Reads what the host wrote into the receive queue (stops while the queue is full).
  void poll_rx();
  // True when received bytes wait for the AVR.
  bool rx_pending() const { return !rx_queue_.empty(); }
  // Takes the next received byte (rx_pending() must be true).
  uint8_t rx_pop();
  // Queues one byte the AVR sent.
  void tx_push(uint8_t byte);
  // Writes queued bytes to the host as far as the pty accepts them.
  void flush_tx();

  // Bytes read from the host.
  uint64_t rx_bytes() const { return rx_bytes_; }
  // Bytes handed to the pty for the host.
  uint64_t tx_bytes() const { return tx_bytes_; }
  // Bytes from the AVR dropped because nobody read them.
  uint64_t tx_dropped() const { return tx_dropped_; }

 private:
  static constexpr size_t kRxQueueMax = 64 * 1024;
  static constexpr size_t kTxQueueMax = 64 * 1024;
  int master_fd_ = -1;
  int slave_fd_ = -1;
  std::string slave_path_;
  std::string link_path_;
  std::deque<uint8_t> rx_queue_;
  std::vector<uint8_t> tx_queue_;
  uint64_t rx_bytes_ = 0;
  uint64_t tx_bytes_ = 0;
  uint64_t tx_dropped_ = 0;
};

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_PTY_LINK_H
