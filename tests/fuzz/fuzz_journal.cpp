// libFuzzer target: the resume journal (eval::parseJournal; docs/sweeps.md, "Resuming"). Contract:
// the text reads, or JournalError with one line naming the file. What reads is consistent: the
// intact prefix is within the text, and that prefix alone reads to the same records with no torn
// tail; the records written back by the journal's own format read to the same records.
#include <map>
#include <string>

#include "eval/tools/journal.hpp"
#include "fuzz_support.hpp"

namespace {
const std::string kFile = "runs/x/results.journal";
const std::string kIdentity = "0123456789abcdef";
constexpr std::size_t kItems = 64;

std::string hex8(std::uint32_t v) {
  static const char* digits = "0123456789abcdef";
  std::string s(8, '0');
  for (int i = 7; i >= 0; --i, v >>= 4) s[std::size_t(i)] = digits[v & 0xF];
  return s;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace ambler;
  const std::string text = fuzz::text(data, size);
  eval::JournalContents c;
  try {
    c = eval::parseJournal(text, kFile, kIdentity, kItems);
  } catch (const eval::JournalError& e) {
    fuzz::checkMessage(e, kFile);
    return 0;
  }
  if (c.valid_bytes > text.size()) fuzz::finding("the intact prefix is longer than the text");
  try {
    const eval::JournalContents prefix = eval::parseJournal(text.substr(0, c.valid_bytes), kFile, kIdentity, kItems);
    if (prefix.records != c.records || prefix.torn_tail) fuzz::finding("the intact prefix reads differently");
    if (c.valid_bytes == 0 && !c.records.empty()) fuzz::finding("records without a header");
    std::string back = "ambler-journal 1 " + kIdentity + "\n";
    for (const auto& [item, payload] : c.records) {
      if (payload.find('\n') != std::string::npos) fuzz::finding("a payload holds a line break");
      back += std::to_string(item) + " " + hex8(eval::crc32(payload)) + " " + payload + "\n";
    }
    if (eval::parseJournal(back, kFile, kIdentity, kItems).records != c.records)
      fuzz::finding("the records written back read differently");
  } catch (const eval::JournalError& e) {
    fuzz::finding(std::string("a journal that read is refused when read again: ") + e.what());
  }
  return 0;
}
