// Showing the progress of a long-running operation while `pf` waits for it:
// a bar redrawn in place on a terminal, plain lines (only when the figures
// change) when stderr is a file or a pipe.
//
//   ProgressReporter progress(stderr, isatty(fileno(stderr)));
//   progress.Update("renderJobs/r1", metadata);  // "[#####-----]  52%  13/25 frames  rendering"
//   progress.Finish();
#ifndef POINTFORWARD_CLIENT_REMOTE_PROGRESS_H_
#define POINTFORWARD_CLIENT_REMOTE_PROGRESS_H_

#include <cstdio>
#include <string>

#include "pointforward/v1/resources.pb.h"

namespace pf {

// Returns the fraction done in [0, 1]: metadata.fraction when set, else
// frames_done / frames_total, else 0.
double ProgressFraction(const pointforward::v1::OperationMetadata& metadata);

// Returns the terminal form, `width` cells wide:
// "[#####-----]  52%  13/25 frames  rendering" (frames and stage left out
// when unknown).
std::string FormatProgressBar(const pointforward::v1::OperationMetadata& metadata, int width = 10);

// Returns the log form: "renderJobs/X: RUNNING 13/25 frames (52%) rendering".
std::string FormatProgressLine(const std::string& name,
                               const pointforward::v1::OperationMetadata& metadata);

class ProgressReporter {
 public:
  // Writes to `out`; `interactive` selects the redrawn bar over plain lines.
  ProgressReporter(std::FILE* out, bool interactive) : out_(out), interactive_(interactive) {}

  // Shows the progress of job `name`. Prints nothing when the text would be
  // the same as last time.
  void Update(const std::string& name, const pointforward::v1::OperationMetadata& metadata);

  // Ends the bar's line on a terminal; call once the wait is over.
  void Finish();

 private:
  std::FILE* out_;
  bool interactive_;
  std::string last_;  // The text shown last.
};

}  // namespace pf

#endif  // POINTFORWARD_CLIENT_REMOTE_PROGRESS_H_
