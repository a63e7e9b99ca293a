// fuzz_replies.cpp: libFuzzer target for the host's side of the link: any bytes from a board
// go through the frame decoder, and every frame through the reply parsers, which must refuse
// what is malformed with an exception and never crash.
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "board/board.h"
#include "stepchoir_protocol.h"

// Called by libFuzzer with each input.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  sc::FrameDecoder dec;
  for (size_t i = 0; i < size; ++i) {
    if (dec.push(data[i]) != sc::kFrameOk) continue;
    const uint8_t *p = dec.payload();
    const uint8_t len = dec.payload_len();
    try {
      if (p[0] == sc::kMsgCaps) stepchoir::parse_caps(p, len);
      if (p[0] == sc::kMsgStatus) stepchoir::parse_status(p, len);
    } catch (const std::exception &) {
    }
  }
  return 0;
}
