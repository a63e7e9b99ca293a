// printer_arrangement.h: a song with more voices than a printer has axes, as the arranger
// (player/arranger.h) plays it on that many motors, for `stepchoir gcode`.
#ifndef STEPCHOIR_HOST_PLAYER_PRINTER_ARRANGEMENT_H
#define STEPCHOIR_HOST_PLAYER_PRINTER_ARRANGEMENT_H

#include <string>
#include <vector>

#include "song/gcode.h"
#include "song/song.h"

namespace stepchoir {

// The song as the arranger plays it on `axes` motors (melody first, then bass; notes folded by
// octaves under each axis's max feed at spc steps a cycle): one voice a motor (track = the
// motor, channel 0), for plan_gcode to give each axis its voice. Adds a line on what it kept
// to `warnings`. Called from: `stepchoir gcode`, its tests.
Song arrange_for_printer(const Song &song, const Printer &printer, size_t axes, double spc,
                         std::vector<std::string> &warnings);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PLAYER_PRINTER_ARRANGEMENT_H
