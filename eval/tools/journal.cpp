#include "eval/tools/journal.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <sstream>

namespace ambler::eval {
namespace {

constexpr std::string_view kMagic = "ambler-journal 1 ";

std::array<std::uint32_t, 256> crcTable() {
  std::array<std::uint32_t, 256> t{};
  for (std::uint32_t n = 0; n < 256; ++n) {
    std::uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1U) ? 0xEDB88320U ^ (c >> 1) : c >> 1;
    t[n] = c;
  }
  return t;
}

std::string hex(std::uint64_t v, int digits) {
  std::string s(std::size_t(digits), '0');
  for (int i = digits - 1; i >= 0; --i, v >>= 4) s[std::size_t(i)] = "0123456789abcdef"[v & 0xF];
  return s;
}

std::string header(std::string_view identity) { return std::string(kMagic) + std::string(identity) + "\n"; }

std::string systemError(int err) { return std::strerror(err); }

}  // namespace

std::uint32_t crc32(std::string_view bytes) {
  static const auto table = crcTable();
  std::uint32_t c = 0xFFFFFFFFU;
  for (const char ch : bytes) c = table[(c ^ std::uint8_t(ch)) & 0xFFU] ^ (c >> 8);
  return c ^ 0xFFFFFFFFU;
}

JournalContents parseJournal(std::string_view text, const std::filesystem::path& file, std::string_view identity,
                             std::size_t items) {
  const std::string where = file.string() + ": ";
  JournalContents out;
  const std::string expected = header(identity);
  const std::size_t eol = text.find('\n');
  if (eol == std::string_view::npos) {
    // Killed while the header was written: nothing recorded yet.
    if (std::string_view(expected).substr(0, text.size()) == text) return out;
    throw JournalError(where + "not an ambler journal (its first line is not \"" +
                       std::string(kMagic) + "<identity>\"); remove it or run without --resume");
  }
  const std::string_view first = text.substr(0, eol + 1);
  if (first != expected) {
    if (first.substr(0, kMagic.size()) == kMagic)
      throw JournalError(where + "recorded for another sweep or basin, or with other options (its identity "
                                 "differs); run without --resume to start over, or give this one its own --out");
    throw JournalError(where + "not an ambler journal (its first line is not \"" + std::string(kMagic) +
                       "<identity>\"); remove it or run without --resume");
  }
  std::size_t at = eol + 1;
  out.valid_bytes = at;
  for (std::size_t line = 2; at < text.size(); ++line) {
    const std::size_t end = text.find('\n', at);
    const bool last = end == std::string_view::npos || end + 1 == text.size();
    const std::string_view record = text.substr(at, end == std::string_view::npos ? text.size() - at : end - at);
    std::string cause;
    std::size_t item = 0;
    if (end == std::string_view::npos) {
      cause = "cut short (no end of line)";
    } else {
      const std::size_t s1 = record.find(' ');
      const std::size_t s2 = s1 == std::string_view::npos ? s1 : record.find(' ', s1 + 1);
      std::uint32_t sum = 0;
      if (s2 == std::string_view::npos || s2 - s1 != 9 ||
          std::from_chars(record.data(), record.data() + s1, item).ptr != record.data() + s1 ||
          std::from_chars(record.data() + s1 + 1, record.data() + s2, sum, 16).ptr != record.data() + s2) {
        cause = "not \"<item> <checksum> <result>\"";
      } else if (crc32(record.substr(s2 + 1)) != sum) {
        cause = "checksum mismatch";
      } else if (item >= items) {
        throw JournalError(where + "line " + std::to_string(line) + ": item " + std::to_string(item) +
                           " is out of range (there are " + std::to_string(items) + ")");
      } else if (!out.records.emplace(item, std::string(record.substr(s2 + 1))).second) {
        throw JournalError(where + "line " + std::to_string(line) + ": item " + std::to_string(item) +
                           " is recorded twice");
      }
    }
    if (!cause.empty()) {
      // The last record may be one an interruption cut short: dropped, and run again.
      if (last) {
        out.torn_tail = true;
        return out;
      }
      throw JournalError(where + "line " + std::to_string(line) + ": damaged record (" + cause +
                         ") followed by others; the journal is corrupt: run without --resume to start over");
    }
    at = end + 1;
    out.valid_bytes = at;
  }
  return out;
}

JournalWriter::JournalWriter(const std::filesystem::path& file, std::string_view identity, bool resume,
                             std::size_t valid_bytes)
    : file_(file) {
  fd_ = ::open(file.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | (resume ? 0 : O_TRUNC), 0644);
  if (fd_ < 0) throw JournalError(file.string() + ": cannot open the journal: " + systemError(errno));
  if (resume && ::ftruncate(fd_, off_t(valid_bytes)) != 0) {
    const int err = errno;
    ::close(fd_);
    throw JournalError(file.string() + ": cannot drop the journal's torn last record: " + systemError(err));
  }
  if (::lseek(fd_, 0, SEEK_END) < 0) {
    const int err = errno;
    ::close(fd_);
    throw JournalError(file.string() + ": cannot seek the journal: " + systemError(err));
  }
  size_ = resume ? valid_bytes : 0;
  if (size_ == 0) {
    try {
      writeAll(header(identity));
    } catch (...) {
      ::close(fd_);
      throw;
    }
  }
}

JournalWriter::~JournalWriter() {
  if (fd_ >= 0) ::close(fd_);
}

void JournalWriter::writeAll(const std::string& bytes) {
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : ENOSPC;
      // Leave no torn record in front of a later one: cut back to the last whole record.
      if (::ftruncate(fd_, off_t(size_)) == 0) ::lseek(fd_, off_t(size_), SEEK_SET);
      throw JournalError(file_.string() + ": cannot record a finished item: " + systemError(err));
    }
    written += std::size_t(n);
  }
  if (::fdatasync(fd_) != 0) {
    const int err = errno;
    if (::ftruncate(fd_, off_t(size_)) == 0) ::lseek(fd_, off_t(size_), SEEK_SET);
    throw JournalError(file_.string() + ": cannot flush the journal to the disk: " + systemError(err));
  }
  size_ += bytes.size();
}

void JournalWriter::append(std::size_t item, std::string_view payload) {
  if (payload.find('\n') != std::string_view::npos)
    throw std::logic_error("journal payload holds a line break");
  writeAll(std::to_string(item) + " " + hex(crc32(payload), 8) + " " + std::string(payload) + "\n");
}

std::vector<std::size_t> unrecordedItems(const JournalContents& done, const std::vector<std::size_t>& todo,
                                         const std::filesystem::path& file, const std::string& items,
                                         const std::string& scope,
                                         const std::function<void(std::size_t, const std::string&)>& recorded) {
  std::vector<std::size_t> pending;
  for (std::size_t i = 0; i < todo.size(); ++i) {
    const auto it = done.records.find(todo[i]);
    if (it == done.records.end()) {
      pending.push_back(i);
    } else {
      recorded(i, it->second);
    }
  }
  if (done.records.size() != todo.size() - pending.size())
    throw JournalError(file.string() + ": records " + items + " that are not in this " + scope +
                       "; run without --resume to start over");
  return pending;
}

JournalContents readJournal(const std::filesystem::path& file, std::string_view identity, std::size_t items) {
  if (!std::filesystem::exists(file)) return {};
  std::ifstream in(file, std::ios::binary);
  if (!in) throw JournalError(file.string() + ": cannot read the journal: " + systemError(errno));
  std::ostringstream text;
  text << in.rdbuf();
  return parseJournal(text.str(), file, identity, items);
}

Journal openJournal(const std::filesystem::path& file, std::string_view identity, std::size_t items, bool resume) {
  Journal j;
  const bool exists = std::filesystem::exists(file);
  if (resume) j.done = readJournal(file, identity, items);
  j.writer = std::make_unique<JournalWriter>(file, identity, resume && exists, j.done.valid_bytes);
  return j;
}

}  // namespace ambler::eval
