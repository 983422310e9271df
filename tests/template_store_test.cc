// LoadTemplateStore: every cache in a directory, refused files with their reasons.
#include "service/template_store.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "synthetic_scene.h"
#include "templates/cache.h"
#include "test_util.h"

namespace g6d {
namespace {

// A tiny bank (6 views) so that the test is quick; only loading is under test.
TemplateBank TinyBank(const std::string& object_id) {
  TemplateBuildOptions options;
  options.views.num_directions = 6;
  options.views.num_inplane = 1;
  InlineExecutor executor;
  return BuildTemplateBank(test::MakeTexturedBox(0.08, 0.06, 0.04, 3), object_id, options,
                           &executor);
}

TEST(LoadTemplateStore, LoadsCachesAndRefusesTheRestWithReasons) {
  const std::string dir = test::TempDir("template_store");
  const TemplateBank bank = TinyBank("obj_000001");
  WriteTemplateCache(bank, dir + "/a_obj_000001.g6dcache");
  WriteTemplateCache(TinyBank("obj_000002"), dir + "/b_obj_000002.g6dcache");
  WriteTemplateCache(bank, dir + "/c_duplicate.g6dcache");  // same object id again
  std::ofstream(dir + "/d_notes.txt") << "not a cache";
  {
    // A truncated copy of a good cache.
    std::ifstream in(dir + "/a_obj_000001.g6dcache", std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir + "/e_truncated.g6dcache", std::ios::binary)
        << bytes.substr(0, bytes.size() / 2);
  }
  std::filesystem::create_directories(dir + "/subdir");  // ignored: not a regular file

  const TemplateStore store = LoadTemplateStore(dir);
  ASSERT_EQ(store.loaded.size(), 2u);
  EXPECT_EQ(store.loaded[0].object_id, "obj_000001");
  EXPECT_EQ(store.loaded[0].num_templates, 6);
  EXPECT_EQ(store.loaded[1].object_id, "obj_000002");
  EXPECT_EQ(store.ObjectIds(), (std::vector<std::string>{"obj_000001", "obj_000002"}));
  ASSERT_EQ(store.refused.size(), 3u);
  EXPECT_NE(store.refused[0].path.find("c_duplicate"), std::string::npos);
  EXPECT_NE(store.refused[0].reason.find("duplicate object id 'obj_000001'"), std::string::npos);
  EXPECT_NE(store.refused[1].path.find("d_notes.txt"), std::string::npos);
  EXPECT_NE(store.refused[1].reason.find("bad magic"), std::string::npos)
      << store.refused[1].reason;
  EXPECT_NE(store.refused[2].path.find("e_truncated"), std::string::npos);
  EXPECT_FALSE(store.refused[2].reason.empty());
  EXPECT_EQ(store.banks.at("obj_000002")->object_id, "obj_000002");
  std::filesystem::remove_all(dir);
}

TEST(LoadTemplateStore, AnEmptyDirectoryIsFineAMissingOneIsNot) {
  const std::string dir = test::TempDir("template_store_empty");
  EXPECT_TRUE(LoadTemplateStore(dir).banks.empty());
  EXPECT_THROW(LoadTemplateStore(dir + "/missing"), Error);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace g6d
