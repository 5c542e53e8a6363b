#pragma once
// A small command-line parser for liloc's programs: `--name value` options, `--flag`
// switches and positional arguments, with generated --help text.

#include <string>
#include <vector>

namespace liloc {

// The items of a list option ("vlp16,hdl32"), in order; empty items are dropped.
std::vector<std::string> split_list(const std::string& text, char separator = ',');

class CommandLine {
 public:
  CommandLine(std::string program, std::string summary);

  // --name VALUE, stored in *value; its current content is the default.
  void add_option(const std::string& name, std::string* value, const std::string& help);
  void add_option(const std::string& name, double* value, const std::string& help);
  void add_option(const std::string& name, int* value, const std::string& help);
  // --name, sets *value to true.
  void add_flag(const std::string& name, bool* value, const std::string& help);
  // Arguments without a leading "--", in order: exactly `count` of them, or any number
  // (none included) with count 0.
  void add_positional(const std::string& name, std::vector<std::string>* values,
                      const std::string& help, size_t count);

  // Returns false after printing the usage if --help was given. Throws
  // std::invalid_argument naming the option on an unknown option, a missing or
  // malformed value, or missing positional arguments.
  bool parse(int argc, const char* const* argv);

  std::string usage() const;

 private:
  enum class Kind { kString, kDouble, kInt, kFlag };
  struct Option {
    std::string name;
    Kind kind;
    void* target;
    std::string help;
    std::string default_text;
  };
  const Option* find(const std::string& name) const;

  std::string program_;
  std::string summary_;
  std::vector<Option> options_;
  std::string positional_name_;
  std::string positional_help_;
  std::vector<std::string>* positional_ = nullptr;
  size_t positional_count_ = 0;  // 0: any number
};

}  // namespace liloc
