// jack_period.cpp: see jack_period.h.
#include "live/jack_period.h"

#include <jack/jack.h>

namespace stepchoir {

double jack_period_us() {
  jack_status_t status;
  jack_client_t *client = jack_client_open("stepchoir period", JackNoStartServer, &status);
  if (!client) return 0;
  const double frames = jack_get_buffer_size(client), rate = jack_get_sample_rate(client);
  jack_client_close(client);
  return rate > 0 ? frames / rate * 1e6 : 0;
}

}  // namespace stepchoir
