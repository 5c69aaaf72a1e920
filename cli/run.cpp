#include "cli/run.hpp"

#include <malloc.h>
#include <opencv2/core/utils/logger.hpp>

#include <algorithm>
#include <iostream>
#include <string>
#include <vector>

#include "fitting/methods.hpp"
#include "pipeline/error.hpp"
#include "pipeline/stage.hpp"

namespace hedgefit::cli {

namespace {

std::vector<std::string> CommandNames(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands({})) names.push_back(sub->get_name());
  return names;
}

std::vector<std::string> FlagNames(const CLI::App& cmd) {
  std::vector<std::string> names;
  for (const CLI::Option* o : cmd.get_options()) {
    for (const std::string& n : o->get_lnames()) names.push_back("--" + n);
  }
  return names;
}

// " (did you mean 'measure'?)", or "" when nothing is close.
std::string DidYouMeanHint(const std::string& word, const std::vector<std::string>& candidates) {
  const std::string best = pipeline::DidYouMean(word, candidates);
  return best.empty() ? "" : " (did you mean '" + best + "'?)";
}

// A parse error as one line: the command the user was in (so the help pointed to is the one with
// its options), the words it did not take (a file given without its option, say).
int ReportParseError(const CLI::App& app, const CLI::ParseError& e) {
  std::string command = "hedgefit", unexpected;
  std::vector<std::string> words;
  const CLI::App* deepest = &app;
  for (const CLI::App* at = &app; at != nullptr;) {
    for (const std::string& word : at->remaining()) {
      unexpected += (unexpected.empty() ? "'" : ", '") + word + "'";
      words.push_back(word);
    }
    deepest = at;
    const auto subs = at->get_subcommands();
    at = subs.empty() ? nullptr : subs.front();
    if (at != nullptr) command += " " + at->get_name();
  }
  if (command == "hedgefit") {
    std::cerr << "hedgefit: " << (unexpected.empty() ? std::string(e.what()) : "unknown command " + unexpected)
              << (words.empty() ? "" : DidYouMeanHint(words.front(), CommandNames(app))) << "; run 'hedgefit --help'\n";
    return kExitBadInput;
  }
  std::string hint;
  for (const std::string& word : words) {
    if (hint.empty() && word.rfind("--", 0) == 0) hint = DidYouMeanHint(word.substr(0, word.find('=')), FlagNames(*deepest));
  }
  std::cerr << "hedgefit: " << command.substr(std::string("hedgefit ").size()) << ": " << e.what() << hint;
  if (!unexpected.empty() && std::string(e.what()).find("not expected") == std::string::npos) {
    std::cerr << " (not taken: " << unexpected << "; files are given with their options)";
  } else if (std::any_of(words.begin(), words.end(), [](const std::string& w) { return w.rfind("-", 0) != 0; })) {
    std::cerr << " (files are given with their options)";
  }
  std::cerr << "; run '" << command << " --help'\n";
  return kExitBadInput;
}

}  // namespace

int RunCommandLine(CLI::App& app, int argc, char** argv, const CommandFn* run) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return ReportParseError(app, e);
  }
  try {
    return *run ? (*run)() : kExitBadInput;
  } catch (const ProcessingError& e) {
    std::cerr << "hedgefit: " << e.what() << "\n";
    return kExitProcessing;
  } catch (const Error& e) {
    std::cerr << "hedgefit: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::bad_alloc&) {
    std::cerr << "hedgefit: out of memory; process a smaller cloud or downsample first (filters.voxel_grid)\n";
    return kExitProcessing;
  } catch (const std::exception& e) {
    std::cerr << "hedgefit: internal error: " << e.what() << "\n";
    return kExitProcessing;
  }
}

void PrepareProcess() {
  // Each capture allocates and frees images of several megabytes (rectified views, B-spline
  // coefficients, disparity maps). glibc serves blocks that large from fresh mmap'd pages that the
  // kernel must fault in and zero every time: a tenth of a garden capture's CPU time. Served
  // from the heap and reused instead, a row of three hedges measures 5 % faster in `stream`
  // (488-497 -> 460-465 ms per frame) and peaks lower (433 -> 392 MB).
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  // hedgefit reports problems itself, one line each: OpenCV's own warnings would come first.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  hedgefit::fitting::QuietSolverWarnings();  // and Ceres' (glog) warnings: each fit reports its own trouble
}

}  // namespace hedgefit::cli
