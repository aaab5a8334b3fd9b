// The progress line lancer's CLI draws on a terminal while it renders.
#pragma once

#include <string>

namespace lancer {

// One line, at most `columns` characters (never wraps, so '\r' redraws it in place): a bar, the
// percentage, rows done, elapsed time, rate and the time left, dropping the least useful parts
// first when the terminal is narrow.
std::string progress_line(int done, int all, double elapsed_s, int columns);

// "0.8 s", "12.4 s", "3 min 05 s", "1 h 02 min".
std::string format_duration(double seconds);

}  // namespace lancer
