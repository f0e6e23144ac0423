#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "avsp_terrain/terrain_objects.hpp"

using namespace avsp::terrain;

namespace
{
TerrainObject object(ObjectType type, double x, double y, double length, double width, double strength,
                     double yaw = 0.0)
{
  TerrainObject o;
  o.type = type;
  o.x = x;
  o.y = y;
  o.length = length;
  o.width = width;
  o.height = 2.0;
  o.strength = strength;
  o.yaw = yaw;
  return o;
}
}  // namespace

TEST(ObjectSet, RegionQueryFindsExactlyTheOverlappingFootprints)
{
  ObjectSet set(5.0);
  const auto rock = set.add(object(ObjectType::kRock, 1.0, 1.0, 1.0, 1.0, INFINITY));
  const auto fence = set.add(object(ObjectType::kFence, 20.0, 0.0, 30.0, 0.1, 2000.0));  // spans 5..35 m in x
  const auto shrub = set.add(object(ObjectType::kShrub, 50.0, 50.0, 1.0, 1.0, 800.0));
  EXPECT_EQ(set.query(0.0, 0.0, 2.0, 2.0), (std::vector<std::uint32_t>{ rock }));
  // A box far from the fence's centre but over its far end still finds it.
  EXPECT_EQ(set.query(33.0, -1.0, 34.0, 1.0), (std::vector<std::uint32_t>{ fence }));
  EXPECT_EQ(set.query(0.0, -1.0, 60.0, 60.0), (std::vector<std::uint32_t>{ rock, fence, shrub }));
  EXPECT_TRUE(set.query(60.0, 60.0, 70.0, 70.0).empty());
}

TEST(ObjectSet, PointInsideRotatedFootprint)
{
  ObjectSet set;
  // A 4 m x 1 m barrier rotated 90 deg: it extends along y.
  const auto id = set.add(object(ObjectType::kBarrier, 0.0, 0.0, 4.0, 1.0, INFINITY, M_PI / 2));
  EXPECT_EQ(set.at(0.0, 1.9), (std::vector<std::uint32_t>{ id }));
  EXPECT_TRUE(set.at(1.9, 0.0).empty());
}

TEST(ObjectSet, ToppleableFallsAndStaysRigidNever)
{
  ObjectSet set;
  const auto pole = set.add(object(ObjectType::kPole, 0, 0, 0.2, 0.2, 3000.0));
  const auto building = set.add(object(ObjectType::kBuilding, 10, 10, 8, 6, INFINITY));
  EXPECT_FALSE(set.push(pole, 2999.0, 0.0));
  EXPECT_FALSE(set.get(pole).toppled);
  EXPECT_TRUE(set.push(pole, 3000.0, 1.0));
  EXPECT_TRUE(set.get(pole).toppled);
  EXPECT_DOUBLE_EQ(set.get(pole).fall_direction, 1.0);
  EXPECT_FALSE(set.push(pole, 1e9, 2.0));  // already down: stays as it fell
  EXPECT_DOUBLE_EQ(set.get(pole).fall_direction, 1.0);
  EXPECT_FALSE(set.push(building, 1e12, 0.0));
  EXPECT_FALSE(set.get(building).toppled);
  EXPECT_THROW(set.push(99, 1.0, 0.0), std::out_of_range);
}

TEST(ObjectSet, RejectsBadObjects)
{
  ObjectSet set;
  EXPECT_THROW(set.add(object(ObjectType::kRock, 0, 0, 0.0, 1.0, INFINITY)), std::invalid_argument);
  EXPECT_THROW(set.add(object(ObjectType::kRock, NAN, 0, 1.0, 1.0, INFINITY)), std::invalid_argument);
  EXPECT_THROW(set.add(object(ObjectType::kShrub, 0, 0, 1.0, 1.0, -5.0)), std::invalid_argument);
  EXPECT_THROW(ObjectSet(0.0), std::invalid_argument);
  // The error names the object (the id it would have had, its kind and position) and the field.
  set.add(object(ObjectType::kRock, 0, 0, 1.0, 1.0, INFINITY));
  try
  {
    set.add(object(ObjectType::kTree, 3.5, -2, 0.4, NAN, INFINITY));
    ADD_FAILURE() << "a NaN width was accepted";
  }
  catch (const std::invalid_argument& e)
  {
    const std::string what = e.what();
    EXPECT_NE(what.find("object 1 (tree at (3.5, -2))"), std::string::npos) << what;
    EXPECT_NE(what.find("width must be finite and > 0 m, got nan"), std::string::npos) << what;
  }
  TerrainObject tall = object(ObjectType::kPole, 1, 1, 0.1, 0.1, 100.0);
  tall.height = INFINITY;
  EXPECT_THROW(set.add(tall), std::invalid_argument);
  EXPECT_EQ(set.size(), 1u);
  EXPECT_EQ(objectTypeFromString("fence"), ObjectType::kFence);
  EXPECT_THROW(objectTypeFromString("tank"), std::invalid_argument);
}

// A topple reported by another process lands exactly as the local push would; bad reports
// change nothing and say why.
TEST(ObjectSet, AppliesReportedTopplesAndRefusesBadOnes)
{
  ObjectSet set;
  TerrainObject shrub;
  shrub.type = ObjectType::kShrub;
  shrub.x = 1.0;
  shrub.length = shrub.width = 1.0;
  shrub.height = 1.2;
  shrub.strength = 800.0;
  TerrainObject rock = shrub;
  rock.type = ObjectType::kRock;
  rock.strength = std::numeric_limits<double>::infinity();
  const std::uint32_t a = set.add(shrub), b = set.add(rock);
  std::string why;
  EXPECT_FALSE(set.applyToppled(7, 0.0, why));
  EXPECT_NE(why.find("no object with id 7"), std::string::npos) << why;
  EXPECT_FALSE(set.applyToppled(b, 0.0, why));
  EXPECT_NE(why.find("rigid"), std::string::npos) << why;
  EXPECT_FALSE(set.get(b).toppled);
  EXPECT_FALSE(set.applyToppled(a, std::nan(""), why));
  EXPECT_FALSE(set.get(a).toppled);
  EXPECT_TRUE(set.applyToppled(a, 1.25, why));
  EXPECT_TRUE(set.get(a).toppled);
  EXPECT_EQ(set.get(a).fall_direction, 1.25);
  EXPECT_TRUE(set.applyToppled(a, -2.0, why));  // already down: it stays where it fell
  EXPECT_EQ(set.get(a).fall_direction, 1.25);
}
