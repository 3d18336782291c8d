// The job loop of `ambler sweep` and `ambler basin` (eval/tools/jobs.hpp).
#include "eval/tools/jobs.hpp"

#include <algorithm>
#include <atomic>
#include <mutex>
#include <thread>

namespace ambler::eval {

std::optional<JobFailure> runJobs(const std::vector<std::size_t>& todo, const std::vector<std::size_t>& pending,
                                  int jobs, JournalWriter& journal, Progress& progress,
                                  const std::function<JobRecord(std::size_t i)>& work) {
  std::mutex mutex;  // guards the journal, the progress and the failures
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  std::optional<JobFailure> failure;          // the failed item of lowest number
  std::optional<std::string> journal_error;   // the journal could not be written
  const auto loop = [&] {
    for (std::size_t p; !stop && (p = next++) < pending.size();) {
      const std::size_t i = pending[p];
      try {
        const JobRecord r = work(i);
        const std::lock_guard lock(mutex);
        journal.append(todo[i], r.payload);
        progress.step(r.progress);
      } catch (const JournalError& e) {
        stop = true;
        const std::lock_guard lock(mutex);
        if (!journal_error) journal_error = e.what();
      } catch (const std::exception& e) {
        stop = true;
        const std::lock_guard lock(mutex);
        if (!failure || todo[i] < failure->item) failure = JobFailure{todo[i], e.what()};
      }
    }
  };
  const std::size_t threads = std::min<std::size_t>(std::size_t(std::max(jobs, 1)), pending.size());
  if (threads <= 1) {
    loop();
  } else {
    std::vector<std::jthread> pool;
    for (std::size_t t = 0; t < threads; ++t) pool.emplace_back(loop);
  }
  if (journal_error) throw JournalError(*journal_error);
  return failure;
}

}  // namespace ambler::eval
