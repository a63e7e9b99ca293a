// pty_link.h: the board's serial port as a pseudo-terminal, with byte queues both ways (POSIX).
#ifndef STEPCHOIR_VBOARD_PTY_LINK_H
#define STEPCHOIR_VBOARD_PTY_LINK_H

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "usb_bridge.h"

namespace vboard {

// Owns a raw pty pair. The host opens slave_path(); the simulator loop calls poll_rx() and
// flush_tx() without ever blocking, and while it paces it waits on rx_wake_fd(), so that host
// bytes end its sleep. A slave fd stays open here so the pty does not hang up when the host
// closes it. Bytes for a host that does not read are buffered up to a limit, then dropped and
// counted. Between the pty and the board's UART sits a USB bridge model (usb_bridge.h; ideal
// unless set_bridge gives another), on host time: the loop's set_now_ns between chunks for what
// the loop does (poll_rx, flush_tx), each byte's own cycle for what the UART does (AvrAdapter).
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

  // The bridge between the pty and the UART (replaces the ideal one; before any byte).
  void set_bridge(const UsbBridge &bridge) { bridge_ = bridge; }
  const UsbBridge &bridge() const { return bridge_; }
  // Host time now (ns from the start of the simulation, on the host's clock).
  void set_now_ns(uint64_t now_ns) { now_ns_ = now_ns; }
  uint64_t now_ns() const { return now_ns_; }

  // True when the host opened the pty while nobody had it open, since the last call (inotify
  // on the slave): a real port's first open raises DTR, which resets an Uno or a Mega; a second
  // program opening it meanwhile does not, nor does a close.
  bool take_host_open();

  // Reads what the host wrote into the receive queue (stops while the queue is full), as
  // arrived at host time arrival_ns (the loop's host_arrival_ns when pacing, else now).
  void poll_rx(uint64_t arrival_ns);
  // The fd whose readability means host bytes wait (the pty's master), for the loop to wait on
  // while it sleeps; -1 while the receive queue is full (poll_rx leaves the bytes unread then,
  // so the fd would end every wait at once).
  int rx_wake_fd() const { return bridge_.host_bytes_waiting() < kRxQueueMax ? master_fd_ : -1; }
  // Takes the next received byte (its bridge time, rx_next_ns, has come).
  uint8_t rx_pop();
  // Host time (ns) at which the next received byte reaches the UART; UINT64_MAX when none waits.
  uint64_t rx_next_ns() const { return bridge_.next_board_byte_ns(); }
  // Host time (ns) at which the bridge next passes the board's bytes on; UINT64_MAX when none wait.
  uint64_t tx_next_ns() const { return bridge_.next_host_pass_ns(); }
  // Queues one byte the AVR sent at host time now_ns.
  void tx_push(uint8_t byte, uint64_t now_ns);
  // Writes the bytes the bridge has passed to the host by now as far as the pty accepts them;
  // returns how many the bridge passed in this call.
  size_t flush_tx();

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
  int inotify_fd_ = -1;  // opens and closes of the slave
  int host_opens_ = 0;    // the host's open file descriptions of the slave
  std::string slave_path_;
  std::string link_path_;
  UsbBridge bridge_{LinkModel::kIdeal, link_model_timing(LinkModel::kIdeal), 0, 0};
  uint64_t now_ns_ = 0;
  std::vector<uint8_t> tx_queue_;  // bytes the bridge passed to the host, not yet written
  uint64_t rx_bytes_ = 0;
  uint64_t tx_bytes_ = 0;
  uint64_t tx_dropped_ = 0;
};

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_PTY_LINK_H
