#pragma once
// The small command-line plumbing the tools share: usage errors (exit 2) and typed values.

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

namespace rrr_graphslam::tools {

class CommandLine {
 public:
  /// Prints the usage and exits 0 if any argument is -h or --help (as argparse does).
  CommandLine(int argc, char** argv, const char* program, const char* usage)
      : argc_(argc), argv_(argv), program_(program), usage_(usage) {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "-h" || a == "--help") {
        std::cout << usage;
        std::exit(0);
      }
    }
  }

  [[noreturn]] void fail(const std::string& what) const {
    std::cerr << program_ << ": " << what << "\n" << usage_;
    std::exit(2);
  }

  /// The argument after position `i` (advancing i), or a usage error naming `option`.
  std::string value(int& i, const std::string& option) const {
    if (i + 1 >= argc_) fail(option + " needs a value");
    return argv_[++i];
  }

  /// An argument that matched no option: the one input file, or a usage error.
  void positional(const std::string& argument, std::string& input) const {
    if (!argument.empty() && argument[0] == '-') fail("unknown option " + argument);
    if (!input.empty()) fail("more than one input file given");
    input = argument;
  }

  /// `text` as a number in [low, high], or a usage error naming `option`.
  double number(const std::string& option, const std::string& text, double low, double high) const {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || *end != '\0' || !(v >= low && v <= high)) {
      fail(option + " must be a number in [" + std::to_string(low) + ", " + std::to_string(high) +
           "], not '" + text + "'");
    }
    return v;
  }

  /// `text` as an integer in [low, high], or a usage error naming `option`.
  long integer(const std::string& option, const std::string& text, double low, double high) const {
    const double v = number(option, text, low, high);
    if (v != std::floor(v)) fail(option + " must be an integer, not '" + text + "'");
    return static_cast<long>(v);
  }

  /// `text` as true or false, or a usage error naming `option`.
  bool boolean(const std::string& option, const std::string& text) const {
    if (text != "true" && text != "false")
      fail(option + " must be true or false, not '" + text + "'");
    return text == "true";
  }

 private:
  int argc_;
  char** argv_;
  const char* program_;
  const char* usage_;
};

}  // namespace rrr_graphslam::tools
