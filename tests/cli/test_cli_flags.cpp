// The command line's grammar as a user meets it: a mistyped flag is answered
// with the nearest one, and messages name a flag as it was typed.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "cli_run.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

const std::string kDem = bundled_dem("olinda_coast_utm25s_111x111.tif");

TEST(CliFlags, ATypoSuggestsTheNearestFlag) {
  struct Case {
    const char* typed;
    const char* meant;
  };
  for (const Case& c : {Case{"--max-distnace", "--max-distance"}, Case{"--obsrver", "--observer"},
                        Case{"--target-heigth", "--target-height"}, Case{"--algoritm", "--algorithm"}}) {
    const auto r = horizon({"viewshed", kDem, c.typed, "1", "-o", "/tmp/x.tif"});
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("unknown flag '" + std::string(c.typed) + "'; did you mean '" + c.meant + "'?"),
              std::string::npos)
        << r.output;
  }
  // The same in another command.
  const auto los = horizon({"los", kDem, "--from-lat", "1", "--to-lonn", "2"});
  EXPECT_EQ(los.exit_code, 2);
  EXPECT_NE(los.output.find("did you mean '--to-lon'?"), std::string::npos) << los.output;
}

TEST(CliFlags, NothingNearIsNoSuggestion) {
  for (const char* typed : {"--colour", "-q", "--zzzzzzzzzzzz"}) {
    const auto r = horizon({"viewshed", kDem, typed, "1"});
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("unknown flag '" + std::string(typed) + "'"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("did you mean"), std::string::npos) << r.output;
  }
}

}  // namespace
}  // namespace horizon::testing
