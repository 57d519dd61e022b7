#include <gtest/gtest.h>
TEST(Placeholder, cliTestsComeWithTheStage) { SUCCEED(); }
