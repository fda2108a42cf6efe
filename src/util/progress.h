// # implicit: progress bar
//
// A one-line progress bar for long renders, in the spirit of Yocto/GL's
// print_progress: bar, samples done/total, elapsed time and estimated time
// remaining, rewritten in place with '\r' on stderr. The line is built by a
// pure function (format_progress) so that it can be tested; the state lives
// in a progress_state owned by the caller (no global state). Updates must
// come one at a time: from the render loop, or from the render's tile
// callback, which never runs twice at once.
#pragma once

#include <chrono>
#include <cstdio>
#include <string>

namespace implicit {

// -----------------------------------------------------------------------------
// PROGRESS
// -----------------------------------------------------------------------------

// The progress line, without '\r' or newline, e.g.
// "[=====               ]   16/  64 00:04 eta 00:12 render image".
// Counts are clamped to [0, total]; the ETA is "--:--" before the first step.
// With a time `limit` (seconds, 0: none) the ETA never passes it; a
// `converged` fraction in [0, 1] (adaptive sampling; negative: none) is
// shown as "conv 37%".
std::string format_progress(const std::string& message, int current, int total,
    double elapsed_seconds, double limit = 0, double converged = -1);

// Seconds left when `current` of `total` steps took `elapsed_seconds`, each
// step costing the mean of those so far (0 when done, negative before the
// first step: unknown); never past a time `limit` (seconds, 0: none).
double estimate_remaining(
    int current, int total, double elapsed_seconds, double limit = 0);

// A time in seconds as mm:ss (minutes grow past 99; negative or NaN as 0).
std::string format_duration(double seconds);

// State of one progress bar. Printing happens only when enabled.
struct progress_state {
  bool        enabled   = false;
  std::string message   = "";
  int         total     = 0;
  int         current   = 0;
  double      limit     = 0;   // time budget in seconds (0: none)
  double      converged = -1;  // fraction of converged pixels (< 0: none)
  // Where the line goes; stderr unless a test redirects it.
  std::FILE*                            stream = stderr;
  std::chrono::steady_clock::time_point start  = {};
  // Seconds since start at the last print (throttles redraws), and the
  // length of the last line (padded over when a new line is shorter).
  double last_print  = -1;
  size_t last_length = 0;
};

// Start a bar at 0/total; prints the empty bar when enabled.
void start_progress(progress_state& progress, const std::string& message,
    int total, bool enabled);

// Set the samples done and redraw (at most every 0.1 s, and always at total).
void update_progress(progress_state& progress, int current);

// Redraw the final state and end the line; later calls print nothing.
void end_progress(progress_state& progress);

// Whether stderr is a terminal (the CLI shows the bar only then).
bool stderr_is_terminal();

}  // namespace implicit
