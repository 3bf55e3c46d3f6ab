#include <gtest/gtest.h>
TEST(RosFrame, Placeholder) {}
