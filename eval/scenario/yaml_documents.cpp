#include "eval/scenario/yaml_documents.hpp"

#include <yaml-cpp/eventhandler.h>

#include <sstream>

namespace ambler::eval {

namespace {

// Records where each document starts; builds nothing.
class DocumentStarts : public YAML::EventHandler {
 public:
  std::vector<YAML::Mark> starts;
  void OnDocumentStart(const YAML::Mark& mark) override { starts.push_back(mark); }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

}  // namespace

std::vector<YAML::Node> loadAllDocuments(const std::string& text) {
  // A first pass over the events: every document consumes at least one token, so two documents
  // starting at the same place mean the parser is stuck (and LoadAll would never return).
  std::istringstream stream(text);
  YAML::Parser parser(stream);
  DocumentStarts events;
  while (parser.HandleNextDocument(events)) {
    const std::size_t n = events.starts.size();
    if (n >= 2 && events.starts[n - 1].pos == events.starts[n - 2].pos)
      throw YAML::ParserException(events.starts.back(), "unexpected token (it starts no value)");
  }
  return YAML::LoadAll(text);
}

}  // namespace ambler::eval
