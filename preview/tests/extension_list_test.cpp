// extension_listed(): EGL and GL extension lists are matched by whole name.

#include "psrig/preview/extension_list.h"

#include <gtest/gtest.h>

namespace psrig::preview {
namespace {

TEST(ExtensionList, MatchesWholeNamesNotPrefixes) {
  EXPECT_FALSE(extension_listed("EGL_EXT_foo_bar", "EGL_EXT_foo"));
  EXPECT_FALSE(extension_listed("EGL_EXT_foo", "EGL_EXT_foo_bar"));
  EXPECT_FALSE(extension_listed("EGL_KHR_a xEGL_EXT_foo EGL_KHR_b", "EGL_EXT_foo"));
  EXPECT_TRUE(extension_listed("EGL_EXT_foo_bar EGL_EXT_foo", "EGL_EXT_foo"));
}

TEST(ExtensionList, FindsTheFirstMiddleAndLastName) {
  const std::string_view list = "EGL_KHR_a EGL_KHR_b EGL_KHR_c";
  EXPECT_TRUE(extension_listed(list, "EGL_KHR_a"));
  EXPECT_TRUE(extension_listed(list, "EGL_KHR_b"));
  EXPECT_TRUE(extension_listed(list, "EGL_KHR_c"));
  EXPECT_TRUE(extension_listed("EGL_KHR_only", "EGL_KHR_only"));
}

TEST(ExtensionList, ToleratesSpacesAtEitherEnd) {
  EXPECT_TRUE(extension_listed(" EGL_KHR_a EGL_KHR_b ", "EGL_KHR_a"));
  EXPECT_TRUE(extension_listed(" EGL_KHR_a EGL_KHR_b ", "EGL_KHR_b"));
  EXPECT_TRUE(extension_listed("EGL_KHR_a  EGL_KHR_b", "EGL_KHR_b"));
}

TEST(ExtensionList, EmptyListOrNameMatchesNothing) {
  EXPECT_FALSE(extension_listed("", "EGL_KHR_a"));
  EXPECT_FALSE(extension_listed("", ""));
  EXPECT_FALSE(extension_listed("EGL_KHR_a EGL_KHR_b", ""));
  EXPECT_FALSE(extension_listed(" ", ""));
  EXPECT_FALSE(extension_listed("EGL_KHR_a  EGL_KHR_b", ""));
}

}  // namespace
}  // namespace psrig::preview
