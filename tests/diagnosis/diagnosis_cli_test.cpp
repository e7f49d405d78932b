#include <gtest/gtest.h>
TEST(DiagnosisCli, Placeholder) { SUCCEED(); }
