#pragma once
// The resume journal of a sweep or a basin (docs/sweeps.md, "Resuming"): an append-only file with
// one record per finished item (a sweep's run, a basin's draw), so a process killed at any moment
// leaves every finished item recorded and nothing that reads as a result that was not finished.
//
//   ambler-journal 1 <identity>\n            the header: what the items belong to
//   <item> <crc32 of payload, 8 hex> <payload>\n      one per finished item, in finishing order
//
// The payload is one line of JSON (the item's result). A record is appended by one write() and
// flushed to the disk before the item counts as done. A kill can tear only the last record (no
// newline yet, or fewer bytes than written); a reader drops a torn last record and refuses a file
// whose damage is anywhere else.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace ambler::eval {

struct JournalError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// CRC-32 (IEEE 802.3, the polynomial of zlib and PNG) of `bytes`.
std::uint32_t crc32(std::string_view bytes);


struct JournalContents {
  std::map<std::size_t, std::string> records;  // item -> payload
  std::size_t valid_bytes = 0;                 // the length of the intact prefix
  bool torn_tail = false;                      // the last record was cut short and is dropped
};

// Reads a journal's text. `file` names it in messages; `identity` is the header it must carry;
// items must be below `items`. Throws JournalError (one line naming the file and the record) for a
// header of another identity or version, a damaged record that is not the last, a record whose
// checksum fails and is followed by others, a duplicated item or one out of range.
JournalContents parseJournal(std::string_view text, const std::filesystem::path& file, std::string_view identity,
                             std::size_t items);

// Appends records to a journal file. Not thread-safe: callers hold their own lock.
class JournalWriter {
 public:
  // Resume: keeps the first `valid_bytes` of an existing file (dropping a torn tail) and appends
  // after them. Fresh (resume false): starts a new file holding the header alone. Throws
  // JournalError naming the file and the cause when it cannot be opened or written.
  JournalWriter(const std::filesystem::path& file, std::string_view identity, bool resume, std::size_t valid_bytes);
  ~JournalWriter();
  JournalWriter(const JournalWriter&) = delete;
  JournalWriter& operator=(const JournalWriter&) = delete;

  // Appends item's record (payload: one line, no '\n') and flushes it to the disk. Throws
  // JournalError naming the file and the cause (a full disk, a file-size limit) on failure; the
  // records before it stay intact.
  void append(std::size_t item, std::string_view payload);

 private:
  void writeAll(const std::string& bytes);  // whole, flushed; on failure cut back to size_
  std::filesystem::path file_;
  int fd_ = -1;
  std::size_t size_ = 0;  // bytes of whole records (and the header) in the file
};

// Splits a command's items (`todo`, item numbers) by what `done` records: calls `recorded(i,
// payload)` for each index i of todo whose item is recorded and returns the other indices, in
// order. Throws JournalError naming `file` when `done` records an item outside todo ("records
// <items> that are not in this <scope>").
std::vector<std::size_t> unrecordedItems(const JournalContents& done, const std::vector<std::size_t>& todo,
                                         const std::filesystem::path& file, const std::string& items,
                                         const std::string& scope,
                                         const std::function<void(std::size_t, const std::string&)>& recorded);

// What a journal file records: empty contents when there is no file. Throws JournalError as
// parseJournal does, or when the file cannot be read.
JournalContents readJournal(const std::filesystem::path& file, std::string_view identity, std::size_t items);

// The journal of a resumable command: reads what a previous attempt recorded (when `resume`) and
// opens the file for appending (a new file when not resuming or when there is none yet).
struct Journal {
  JournalContents done;
  std::unique_ptr<JournalWriter> writer;
};
Journal openJournal(const std::filesystem::path& file, std::string_view identity, std::size_t items, bool resume);

}  // namespace ambler::eval
