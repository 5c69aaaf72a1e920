#pragma once
/// The one error type hedgefit throws for bad input or options. Its message is a
/// single line naming the file, stage or option at fault and what would fix it;
/// the CLI prints it as-is and exits non-zero.

#include <stdexcept>
#include <string>

namespace hedgefit {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An input file that cannot be read (a damaged or cut-short image, say), or an option the input
/// makes impossible (a nearest depth the rig cannot match in these images): bad input (exit code 1
/// in the CLI) even when found while a pipeline runs, where other errors are processing failures.
class InputError : public Error {
 public:
  using Error::Error;
};

/// Thrown when processing fails on otherwise valid input (exit code 2 in the CLI).
class ProcessingError : public Error {
 public:
  using Error::Error;
};

}  // namespace hedgefit
