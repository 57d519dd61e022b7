#include <gtest/gtest.h>
TEST(Placeholder, paramsTestsComeWithTheStage) { SUCCEED(); }
