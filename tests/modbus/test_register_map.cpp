// Register maps as data: the shipped maps load, values round-trip through their scaling, and broken
// maps are rejected with a message naming the file and the field.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "host/fixture/fixture.h"
#include "host/fixture/register_map.h"

#include <nlohmann/json.hpp>

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace modbus_test_register_map {

using namespace imuforge::fixture;

namespace {
std::string map_path(const char* f) { return std::string(IMUFORGE_SOURCE_DIR) + "/host/fixture/maps/" + f; }

std::string error_of(const std::string& text) {
  try {
    RegisterMap::from_json_text(text, "test.json");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

const char* kHead = R"("format":"imuforge-modbus-map","format_version":1,"model":"m","kind":"chamber",)";
}  // namespace

TEST(ModbusMap, ShippedMapsLoad) {
  const auto t = RegisterMap::load(map_path("imuforge-table.json"));
  EXPECT_EQ(t.kind(), FixtureKind::kRateTable);
  EXPECT_EQ(t.axes(), 3);
  EXPECT_EQ(t.address(t.require("angle"), 2), 1310);
  EXPECT_EQ(t.label(t.require("command"), 1), "axis1.command @1201..1202");
  const auto c = RegisterMap::load(map_path("imuforge-chamber.json"));
  EXPECT_EQ(c.kind(), FixtureKind::kChamber);
  const auto w = RegisterMap::load(map_path("watlow-f4.json"));
  EXPECT_EQ(w.require("air_temp").address, 100);
  EXPECT_EQ(w.require("setpoint").address, 300);
  EXPECT_TRUE(w.require("setpoint").writable);
  EXPECT_FALSE(w.require("air_temp").writable);
}

TEST(ModbusMap, ScalingRoundTrips) {
  const auto t = RegisterMap::load(map_path("imuforge-table.json"));
  const Point& cmd = t.require("command");  // i32, 1e-4 deg, high word first
  auto w = t.encode(cmd, -123.4567);
  ASSERT_EQ(w.size(), 2u);
  const int32_t raw = static_cast<int32_t>((static_cast<uint32_t>(w[0]) << 16) | w[1]);
  EXPECT_EQ(raw, -1234567);
  EXPECT_NEAR(t.decode(cmd, w.data()), -123.4567, 1e-9);
  const auto wat = RegisterMap::load(map_path("watlow-f4.json"));
  const Point& sp = wat.require("setpoint");  // i16 with one implied decimal
  EXPECT_EQ(wat.encode(sp, -40.0)[0], static_cast<uint16_t>(-400));
  EXPECT_NEAR(wat.decode(sp, wat.encode(sp, 85.3).data()), 85.3, 1e-9);
  EXPECT_THROW(wat.encode(sp, 5000.0), std::runtime_error);  // 50000 does not fit in int16
}

TEST(ModbusMap, WordOrderAndFloat) {
  const std::string text = std::string("{") + kHead + R"("word_order":"low_first","points":[
    {"name":"air_temp","address":10,"type":"f32","unit":"degC"},
    {"name":"setpoint","address":12,"type":"u32","scale":0.5,"offset":-100,"access":"rw"}]})";
  const auto m = RegisterMap::from_json_text(text, "t");
  const Point& f = m.require("air_temp");
  auto w = m.encode(f, 21.5f);
  EXPECT_EQ(m.decode(f, w.data()), 21.5);
  const Point& u = m.require("setpoint");
  w = m.encode(u, 40.0);  // raw = (40 + 100) / 0.5 = 280, low word first
  EXPECT_EQ(w[0], 280);
  EXPECT_EQ(w[1], 0);
}

TEST(ModbusMap, BadMapsAreRejectedWithTheCause) {
  EXPECT_NE(error_of("{not json").find("not valid JSON"), std::string::npos);
  EXPECT_NE(error_of(std::string("{") + kHead + R"("points":[{"name":"a","address":1,"type":"u17"}]})").find("unknown type 'u17'"),
            std::string::npos);
  EXPECT_NE(error_of(std::string("{") + kHead + R"("points":[{"name":"a","address":1,"type":"u16","acess":"rw"}]})")
                .find("unknown key 'acess'"),
            std::string::npos);
  const std::string overlap = error_of(std::string("{") + kHead +
                                       R"("points":[{"name":"a","address":1,"type":"i32"},{"name":"b","address":2,"type":"u16"}]})");
  EXPECT_NE(overlap.find("register 2 used by both a @1..2 and b @2"), std::string::npos) << overlap;
  EXPECT_NE(error_of(std::string("{") + kHead + R"("points":[{"name":"a","address":65535,"type":"i32"}]})").find("out of 0..65535"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"format":"imuforge-modbus-map","format_version":1,"model":"m","kind":"oven","points":[]})").find("'kind'"),
            std::string::npos);
  EXPECT_NE(error_of("[]").find("test.json"), std::string::npos);
}

TEST(ModbusMap, StationConfigParsing) {
  nlohmann::json j = {{"name", "chamber-1"}, {"transport", "rtu"}, {"device", "/dev/ttyUSB0"}, {"baud", 19200},
                      {"parity", "E"}, {"unit_id", 3}, {"map", "watlow-f4"},
                      {"limits", {{"max_temp_degC", 85}, {"max_ramp_degC_min", 2}}}};
  const FixtureConfig c = fixture_config_from_json(j, "/nonexistent");
  EXPECT_EQ(c.link.transport, "rtu");
  EXPECT_EQ(c.link.parity, 'E');
  EXPECT_EQ(c.link.unit_id, 3);
  EXPECT_EQ(c.limits.max_temp_degC, 85);
  EXPECT_NE(c.map_path.find("watlow-f4.json"), std::string::npos);
  j["limits"]["max_temp"] = 1;
  try {
    fixture_config_from_json(j, "");
    FAIL() << "unknown limit accepted";
  } catch (const FixtureError& e) {
    EXPECT_NE(std::string(e.what()).find("chamber-1"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("max_temp"), std::string::npos);
  }
  j.erase("limits");
  j["map"] = "no-such-map.json";
  EXPECT_THROW(fixture_config_from_json(j, ""), FixtureError);
}
}  // namespace modbus_test_register_map
