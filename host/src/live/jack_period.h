// jack_period.h: the JACK server's period, asked of the server itself. MIDI through JACK moves
// once a period: a message waits for the next cycle, on average half a period, before a
// client's callback sees it, and a clock follower stamping ticks as they come sees them that
// much late.
#ifndef STEPCHOIR_HOST_LIVE_JACK_PERIOD_H
#define STEPCHOIR_HOST_LIVE_JACK_PERIOD_H

namespace stepchoir {

// The running JACK server's period in microseconds (frames per period over its sample rate);
// 0 when no server runs (one is never started for this). Called from: setup code (MidiIn's
// constructor on the JACK API), on the main thread: it opens and closes a JACK client.
double jack_period_us();

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_JACK_PERIOD_H
