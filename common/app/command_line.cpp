#include "app/command_line.hpp"

#include <iostream>
#include <sstream>
#include <stdexcept>

namespace liloc {

std::vector<std::string> split_list(const std::string& text, char separator) {
  std::vector<std::string> out;
  std::stringstream stream(text);
  for (std::string item; std::getline(stream, item, separator);) {
    if (!item.empty()) {
      out.push_back(item);
    }
  }
  return out;
}

CommandLine::CommandLine(std::string program, std::string summary)
    : program_(std::move(program)), summary_(std::move(summary)) {
  options_.push_back({"help", Kind::kFlag, nullptr, "print this help and exit", ""});
}

void CommandLine::add_option(const std::string& name, std::string* value, const std::string& help) {
  options_.push_back({name, Kind::kString, value, help, *value});
}

void CommandLine::add_option(const std::string& name, double* value, const std::string& help) {
  std::ostringstream s;
  s << *value;
  options_.push_back({name, Kind::kDouble, value, help, s.str()});
}

void CommandLine::add_option(const std::string& name, int* value, const std::string& help) {
  options_.push_back({name, Kind::kInt, value, help, std::to_string(*value)});
}

void CommandLine::add_flag(const std::string& name, bool* value, const std::string& help) {
  options_.push_back({name, Kind::kFlag, value, help, ""});
}

void CommandLine::add_positional(const std::string& name, std::vector<std::string>* values,
                                 const std::string& help, size_t count) {
  positional_name_ = name;
  positional_help_ = help;
  positional_ = values;
  positional_count_ = count;
}

const CommandLine::Option* CommandLine::find(const std::string& name) const {
  for (const Option& o : options_) {
    if (o.name == name) {
      return &o;
    }
  }
  return nullptr;
}

bool CommandLine::parse(int argc, const char* const* argv) {
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg.rfind("--", 0) != 0 || arg.size() == 2) {
      positional.push_back(arg);
      continue;
    }
    std::string name = arg.substr(2);
    std::string value;
    bool has_inline_value = false;
    if (const size_t eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
      has_inline_value = true;
    }
    const Option* option = find(name);
    if (option == nullptr) {
      throw std::invalid_argument("unknown option --" + name + " (see --help)");
    }
    if (name == "help") {
      std::cout << usage();
      return false;
    }
    if (option->kind == Kind::kFlag) {
      *static_cast<bool*>(option->target) = true;
      continue;
    }
    if (!has_inline_value) {
      if (i + 1 >= argc) {
        throw std::invalid_argument("option --" + name + " needs a value");
      }
      value = argv[++i];
    }
    try {
      size_t used = 0;
      switch (option->kind) {
        case Kind::kString:
          *static_cast<std::string*>(option->target) = value;
          used = value.size();
          break;
        case Kind::kDouble:
          *static_cast<double*>(option->target) = std::stod(value, &used);
          break;
        case Kind::kInt:
          *static_cast<int*>(option->target) = std::stoi(value, &used);
          break;
        case Kind::kFlag:
          break;
      }
      if (used != value.size()) {
        throw std::invalid_argument("trailing characters");
      }
    } catch (const std::logic_error&) {
      throw std::invalid_argument("option --" + name + ": malformed value '" + value + "'");
    }
  }
  if (positional_ == nullptr && !positional.empty()) {
    throw std::invalid_argument("unexpected argument '" + positional.front() + "'");
  }
  if (positional_ != nullptr) {
    if (positional.size() < positional_count_) {
      throw std::invalid_argument("missing argument " + positional_name_ + " (see --help)");
    }
    if (positional_count_ > 0 && positional.size() > positional_count_) {
      throw std::invalid_argument("expected " + positional_name_ + ", got " +
                                  std::to_string(positional.size()) + " arguments (see --help)");
    }
    *positional_ = positional;
  }
  return true;
}

std::string CommandLine::usage() const {
  std::ostringstream s;
  s << "usage: " << program_ << " [options]";
  if (positional_ != nullptr) {
    s << " " << positional_name_;
  }
  s << "\n" << summary_ << "\n\n";
  if (positional_ != nullptr) {
    s << "  " << positional_name_ << "\n      " << positional_help_ << "\n";
  }
  for (const Option& o : options_) {
    s << "  --" << o.name;
    if (o.kind != Kind::kFlag) {
      s << " VALUE";
    }
    s << "\n      " << o.help;
    if (!o.default_text.empty()) {
      s << " (default: " << o.default_text << ")";
    }
    s << "\n";
  }
  return s.str();
}

}  // namespace liloc
