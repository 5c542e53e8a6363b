#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "config/yaml_config.hpp"

namespace liloc {
namespace {

struct InnerConfig {
  int count = 3;
  std::vector<double> weights{1.0, 2.0};
  template <class V>
  void visit_fields(V& v) {
    v("count", count);
    v("weights", weights);
  }
};

struct SampleConfig {
  double rate_hz = 10.0;
  bool enabled = true;
  std::string name = "default";
  Eigen::Vector3d offset_m = Eigen::Vector3d::Zero();
  std::array<int, 2> pair{1, 2};
  InnerConfig inner;
  template <class V>
  void visit_fields(V& v) {
    v("rate_hz", rate_hz);
    v("enabled", enabled);
    v("name", name);
    v("offset_m", offset_m);
    v("pair", pair);
    v("inner", inner);
  }
  void validate() const {
    if (rate_hz <= 0) {
      throw std::invalid_argument("rate_hz must be positive");
    }
  }
};

class ConfigFile : public ::testing::Test {
 protected:
  std::string write(const std::string& text) {
    path_ = ::testing::TempDir() + "liloc_config_test_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".yaml";
    std::ofstream(path_) << text;
    return path_;
  }
  void TearDown() override { std::remove(path_.c_str()); }

  // Loads `text` and returns the ConfigError message (empty if it loaded).
  std::string error_of(const std::string& text, const std::string& section = "") {
    try {
      load_config<SampleConfig>(write(text), section);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  }
  std::string path_;
};

TEST_F(ConfigFile, MissingKeysKeepDefaults) {
  const SampleConfig c = load_config<SampleConfig>(write("rate_hz: 20\n"));
  EXPECT_EQ(c.rate_hz, 20.0);
  EXPECT_TRUE(c.enabled);
  EXPECT_EQ(c.name, "default");
  EXPECT_EQ(c.inner.count, 3);
}

TEST_F(ConfigFile, ReadsEveryKindOfField) {
  const SampleConfig c = load_config<SampleConfig>(
      write("rate_hz: 5.5\nenabled: false\nname: campus\noffset_m: [0.1, -0.2, 0.3]\n"
            "pair: [7, 8]\ninner:\n  count: 9\n  weights: [0.5, 0.25, 0.125]\n"));
  EXPECT_EQ(c.rate_hz, 5.5);
  EXPECT_FALSE(c.enabled);
  EXPECT_EQ(c.name, "campus");
  EXPECT_TRUE(c.offset_m.isApprox(Eigen::Vector3d(0.1, -0.2, 0.3)));
  EXPECT_EQ(c.pair[1], 8);
  EXPECT_EQ(c.inner.count, 9);
  ASSERT_EQ(c.inner.weights.size(), 3u);
  EXPECT_EQ(c.inner.weights[2], 0.125);
}

TEST_F(ConfigFile, ReadsASectionAndIgnoresOthers) {
  const SampleConfig c =
      load_config<SampleConfig>(write("other_process:\n  x: 1\nmine:\n  rate_hz: 2\n"), "mine");
  EXPECT_EQ(c.rate_hz, 2.0);
}

TEST_F(ConfigFile, UnknownKeyNamesKeyFileAndLine) {
  const std::string e = error_of("rate_hz: 1\ninner:\n  cuont: 4\n");
  EXPECT_NE(e.find("unknown key 'inner.cuont'"), std::string::npos) << e;
  EXPECT_NE(e.find(path_ + ":3"), std::string::npos) << e;
  EXPECT_NE(e.find("count"), std::string::npos) << "lists the known keys: " << e;
}

TEST_F(ConfigFile, WrongTypeNamesKeyAndValue) {
  const std::string e = error_of("rate_hz: fast\n");
  EXPECT_NE(e.find("key 'rate_hz' must be a number, got 'fast'"), std::string::npos) << e;
  EXPECT_NE(error_of("inner:\n  count: 2.5\n").find("'inner.count' must be an integer"),
            std::string::npos);
  EXPECT_NE(error_of("enabled: maybe\n").find("'enabled' must be true or false"),
            std::string::npos);
  EXPECT_NE(error_of("inner: 3\n").find("'inner' must be a map"), std::string::npos);
  EXPECT_NE(error_of("name: [a, b]\n").find("'name' must be a string"), std::string::npos);
}

TEST_F(ConfigFile, WrongListLengthIsAnError) {
  const std::string e = error_of("offset_m: [1, 2]\n");
  EXPECT_NE(e.find("'offset_m' must be a list of 3 numbers"), std::string::npos) << e;
  EXPECT_NE(error_of("inner:\n  weights: 1\n").find("'inner.weights' must be a list"),
            std::string::npos);
  EXPECT_NE(error_of("inner:\n  weights: [1, x]\n").find("'inner.weights[1]'"), std::string::npos);
}

TEST_F(ConfigFile, ValidateRejectsBadValues) {
  const std::string e = error_of("rate_hz: -1\n");
  EXPECT_NE(e.find("rate_hz must be positive"), std::string::npos) << e;
}

TEST_F(ConfigFile, SyntaxErrorAndMissingFileNameTheFile) {
  const std::string e = error_of("rate_hz: [1, 2\n");
  EXPECT_NE(e.find("YAML syntax error"), std::string::npos) << e;
  EXPECT_NE(e.find(path_), std::string::npos) << e;
  try {
    load_config<SampleConfig>("/nonexistent/liloc.yaml");
    FAIL();
  } catch (const ConfigError& err) {
    EXPECT_NE(std::string(err.what()).find("/nonexistent/liloc.yaml"), std::string::npos);
  }
}

TEST_F(ConfigFile, DumpedConfigLoadsBackEqual) {
  SampleConfig c;
  c.rate_hz = 42.0;
  c.name = "dumped";
  c.inner.weights = {3.0};
  c.offset_m = Eigen::Vector3d(1, 2, 3);
  const SampleConfig back = load_config<SampleConfig>(write(dump_config(c)));
  EXPECT_EQ(back.rate_hz, 42.0);
  EXPECT_EQ(back.name, "dumped");
  EXPECT_EQ(back.inner.weights, std::vector<double>{3.0});
  EXPECT_TRUE(back.offset_m.isApprox(c.offset_m));
}

// Numbers are written as the shortest text that reads back as the same value.
TEST_F(ConfigFile, DumpedNumbersAreShortAndExact) {
  SampleConfig c;
  c.rate_hz = 0.6;
  c.inner.weights = {0.1, 1e-7, 1.0 / 3.0};
  const std::string text = dump_config(c);
  EXPECT_NE(text.find("rate_hz: 0.6\n"), std::string::npos) << text;
  const SampleConfig back = load_config<SampleConfig>(write(text));
  EXPECT_EQ(back.rate_hz, 0.6);
  EXPECT_EQ(back.inner.weights, c.inner.weights);
}

// Values a config must never take: a non-finite number, a key given twice (YAML keeps
// both and the first would win silently), a directory given as the file.
TEST_F(ConfigFile, RefusesNonFiniteNumbersDuplicateKeysAndDirectories) {
  for (const std::string nan : {".nan", ".inf", "-.inf", ".NaN"}) {
    const std::string error = error_of("rate_hz: " + nan + "\n");
    EXPECT_NE(error.find("rate_hz' must be a finite number"), std::string::npos) << error;
  }
  const std::string twice = error_of("rate_hz: 5\nname: a\nrate_hz: 7\n");
  EXPECT_NE(twice.find(":3: key 'rate_hz' is given twice"), std::string::npos) << twice;
  const std::string nested = error_of("inner:\n  count: 1\n  count: 2\n");
  EXPECT_NE(nested.find("key 'inner.count' is given twice"), std::string::npos) << nested;
  try {
    load_config<SampleConfig>(::testing::TempDir());
    FAIL() << "a directory loaded as a config";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("is a directory"), std::string::npos) << e.what();
  }
}

// What dump_config(config, section) prints, load_config(path, section) reads back: a tool's
// --print-config output is a config file for its --config.
TEST_F(ConfigFile, ASectionDumpLoadsBackAsThatSection) {
  SampleConfig config;
  config.rate_hz = 42.5;
  config.inner.count = 9;
  const SampleConfig back = load_config<SampleConfig>(write(dump_config(config, "sim")), "sim");
  EXPECT_DOUBLE_EQ(back.rate_hz, 42.5);
  EXPECT_EQ(back.inner.count, 9);
}

// A program's config: the file given; else ./config/liloc.yaml if the working directory
// has one; else the built-in defaults, so that programs run from any directory. A file
// given but missing is an error.
TEST_F(ConfigFile, ProgramsRunFromAnyDirectory) {
  const std::filesystem::path before = std::filesystem::current_path();
  const std::filesystem::path dir = ::testing::TempDir() + "liloc_config_anywhere";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "config");
  std::filesystem::current_path(dir);
  EXPECT_EQ(load_program_config<SampleConfig>("").rate_hz, 10.0);  // the built-in default
  std::ofstream(dir / "config" / "liloc.yaml") << "rate_hz: 20.0\n";
  EXPECT_EQ(load_program_config<SampleConfig>("").rate_hz, 20.0);
  EXPECT_EQ(load_program_config<SampleConfig>(write("rate_hz: 30.0\n")).rate_hz, 30.0);
  EXPECT_THROW(load_program_config<SampleConfig>("missing.yaml"), ConfigError);
  std::filesystem::current_path(before);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace liloc
