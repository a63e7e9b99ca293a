// board.h: picks the board table for the MCU being compiled for (firmware build only).
#ifndef STEPCHOIR_BOARD_H
#define STEPCHOIR_BOARD_H

#if defined(__AVR_ATmega2560__)
#include "mega_ramps_14.h"
namespace board { namespace active = mega_ramps_14; }
#elif defined(__AVR_ATmega328P__)
#include "uno_cnc_shield_v3.h"
namespace board { namespace active = uno_cnc_shield_v3; }
#else
#error "stepchoir: no board table for this MCU (ATmega328P: uno_cnc_shield_v3, ATmega2560: mega_ramps_14)"
#endif

#if F_CPU != 16000000UL
#error "stepchoir: the board tables and the 1,000,000 baud link assume a 16 MHz clock"
#endif

#endif  // STEPCHOIR_BOARD_H
