#pragma once
// The job loop that `ambler sweep` and `ambler basin` share (docs/sweeps.md, "Resuming"): the items
// a journal has not recorded, run `jobs` at once, each recorded as it finishes, stopping at the
// first failure.
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "eval/tools/journal.hpp"
#include "eval/tools/progress.hpp"
#include "eval/tools/shards.hpp"

namespace ambler::eval {

// The item that failed first (of lowest number) and what it threw.
struct JobFailure {
  std::size_t item = 0;
  std::string message;
};

// What a finished item leaves: its journal record's payload (one line) and its progress line.
struct JobRecord {
  std::string payload;
  std::string progress;
};

// Runs work(i) for every index i of `pending` (indices into `todo`, whose entries are the items'
// numbers), `jobs` at once (one: in this thread). As each finishes, its record is appended to the
// journal and its line given to `progress`, under one lock. An item that throws lets no further
// item start; once the running ones end, the loop returns the failure of lowest item (nullopt:
// every item finished). A JournalError (the journal cannot be written) is rethrown instead.
std::optional<JobFailure> runJobs(const std::vector<std::size_t>& todo, const std::vector<std::size_t>& pending,
                                  int jobs, JournalWriter& journal, Progress& progress,
                                  const std::function<JobRecord(std::size_t i)>& work);

}  // namespace ambler::eval
