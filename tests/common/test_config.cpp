#include <gtest/gtest.h>

#include "sw/common/config.h"

using namespace xbarsim;

TEST(Config, DefaultsAreLoaded) {
  ConfigTree cfg;
  EXPECT_DOUBLE_EQ(cfg.get_double("crossbar.r_wire"), 1.0);
  EXPECT_EQ(cfg.get_string("crossbar.memristor.model"), "linear");
}

TEST(Config, OverrideByDottedKey) {
  ConfigTree cfg = ConfigTree::load("", {"crossbar.r_wire=2.5", "crossbar.memristor.model=sinh"});
  EXPECT_DOUBLE_EQ(cfg.get_double("crossbar.r_wire"), 2.5);
  EXPECT_EQ(cfg.get_string("crossbar.memristor.model"), "sinh");
}

TEST(Config, UnknownKeyIsRejectedWithItsName) {
  try {
    ConfigTree::load("", {"crossbar.r_wir=2"});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("crossbar.r_wir"), std::string::npos) << e.what();
  }
}

TEST(Config, YamlTextMergesAndChecksStructure) {
  ConfigTree cfg;
  cfg.merge_yaml_text("crossbar:\n  r_in: 3\n", "test.yaml");
  EXPECT_DOUBLE_EQ(cfg.get_double("crossbar.r_in"), 3.0);
  EXPECT_THROW(cfg.merge_yaml_text("crossbar: 5\n", "t.yaml"), InputError);
  EXPECT_THROW(cfg.merge_yaml_text("crossbar:\n  memristor: 1\n", "t.yaml"), InputError);
  EXPECT_THROW(cfg.merge_yaml_text("crossbar: [\n", "t.yaml"), InputError);
}

TEST(Config, NonNumericValueNamesKeyAndValue) {
  ConfigTree cfg = ConfigTree::load("", {"crossbar.r_wire=abc"});
  try {
    cfg.get_double("crossbar.r_wire");
    FAIL();
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("crossbar.r_wire"), std::string::npos);
    EXPECT_NE(w.find("abc"), std::string::npos);
  }
}

TEST(Config, ListsAreSweeps) {
  ConfigTree cfg = ConfigTree::load("", {"crossbar.r_wire=[1, 2, 4]"});
  EXPECT_TRUE(cfg.is_list("crossbar.r_wire"));
  EXPECT_EQ(cfg.list_items("crossbar.r_wire").size(), 3u);
  EXPECT_EQ(cfg.sweep_keys(), std::vector<std::string>{"crossbar.r_wire"});
  EXPECT_THROW(cfg.get_double("crossbar.r_wire"), InputError);
  cfg.set("crossbar.r_wire", "4");
  EXPECT_DOUBLE_EQ(cfg.get_double("crossbar.r_wire"), 4.0);
}

TEST(Config, MissingFileIsAnError) { EXPECT_THROW(ConfigTree::load("/nonexistent/x.yaml", {}), InputError); }

TEST(Config, ValidationHelpers) {
  ConfigTree cfg = ConfigTree::load("", {"crossbar.r_wire=-1", "crossbar.memristor.model=foo"});
  EXPECT_THROW(cfg.get_double("crossbar.r_wire"), InputError);
  EXPECT_THROW(require_one_of(cfg, "crossbar.memristor.model", {"linear", "sinh"}), InputError);
}
