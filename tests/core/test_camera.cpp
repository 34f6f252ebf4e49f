#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/projector.hpp"
#include "test_support.hpp"

using namespace fabrica;

namespace {

Camera test_camera(Projection projection) {
  Camera c;
  c.eye = {1.0, 2.0, 10.0};
  c.center = {1.0, 2.0, 0.0};
  c.up = {0.0, 1.0, 0.0};
  c.fov_deg = 40.0;
  c.width = 800;
  c.height = 600;
  c.projection = projection;
  return c;
}

}  // namespace

TEST(Camera, ProjectsCentreToImageCentreAndAxesTheRightWay) {
  for (auto projection : {Projection::perspective, Projection::orthographic}) {
    const Camera c = test_camera(projection);
    const auto centre = project(c, c.center);
    EXPECT_NEAR(centre.pixel.x(), 400.0, 1e-9);
    EXPECT_NEAR(centre.pixel.y(), 300.0, 1e-9);
    EXPECT_NEAR(centre.depth, 10.0, 1e-12);
    EXPECT_GT(project(c, c.center + Vec3(1, 0, 0)).pixel.x(), 400.0);  // world +x is image right
    EXPECT_LT(project(c, c.center + Vec3(0, 1, 0)).pixel.y(),
              300.0);  // world +y is image up (y down)
  }
}

TEST(Camera, TopOfTheFieldOfViewMapsToTheTopRow) {
  const Camera c = test_camera(Projection::perspective);
  const double half = 10.0 * std::tan(20.0 * M_PI / 180.0);
  EXPECT_NEAR(project(c, c.center + Vec3(0, half, 0)).pixel.y(), 0.0, 1e-9);
  EXPECT_NEAR(project(c, c.center + Vec3(half * 800.0 / 600.0, 0, 0)).pixel.x(), 800.0, 1e-9);
}

TEST(Camera, MatricesAgreeWithProject) {
  for (auto projection : {Projection::perspective, Projection::orthographic}) {
    const Camera c = test_camera(projection);
    const auto [n, f] = clip_planes(c, c.center, 3.0);
    EXPECT_GT(n, 0.0);
    EXPECT_GT(f, n);
    const Eigen::Matrix4d m = projection_matrix(c, n, f) * view_matrix(c);
    for (const Vec3& p : {Vec3(1.5, 2.5, 0.3), Vec3(0.2, 1.1, -1.0), Vec3(2.0, 3.0, 1.0)}) {
      const Eigen::Vector4d clip = m * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0);
      const Vec3 ndc = clip.head<3>() / clip.w();
      const auto q = project(c, p);
      EXPECT_NEAR(0.5 * (ndc.x() + 1) * c.width, q.pixel.x(), 1e-9);
      EXPECT_NEAR(0.5 * (1 - ndc.y()) * c.height, q.pixel.y(), 1e-9);
      EXPECT_GT(ndc.z(), -1.0);
      EXPECT_LT(ndc.z(), 1.0);
    }
  }
}

TEST(Camera, ProjectorRaysAndPixelSizesInvertTheProjection) {
  // The viewing ray through a pixel projects back onto that pixel at every
  // depth along it, and one pixel at depth d spans pixel_size(d) mm.
  for (auto projection : {Projection::perspective, Projection::orthographic}) {
    const Camera c = test_camera(projection);
    const Projector projector(c);
    for (const Vec2& pixel : {Vec2(400.0, 300.0), Vec2(12.5, 580.25), Vec2(799.0, 0.5)}) {
      Vec3 origin, direction;
      projector.ray(pixel, origin, direction);
      EXPECT_NEAR(direction.norm(), 1.0, 1e-12);
      for (const double t : {3.0, 10.0, 25.0}) {
        const ProjectedPoint q = projector(origin + t * direction);
        EXPECT_NEAR(q.pixel.x(), pixel.x(), 1e-9);
        EXPECT_NEAR(q.pixel.y(), pixel.y(), 1e-9);
        const ProjectedPoint p = project(c, origin + t * direction);
        EXPECT_EQ(p.pixel, q.pixel);
        EXPECT_EQ(p.depth, q.depth);
      }
    }
    // Half the view height (10 mm * tan 20 deg at the centre) over 300 rows.
    const double size = projector.pixel_size(10.0);
    EXPECT_NEAR(size, 2.0 * 10.0 * std::tan(20.0 * M_PI / 180.0) / 600.0, 1e-12);
    const double dy = project(c, c.center + Vec3(0, size, 0)).pixel.y() - 300.0;
    EXPECT_NEAR(dy, -1.0, 1e-9);
  }
}

TEST(Camera, JsonRoundTripAndExtraKeysIgnored) {
  Camera c = test_camera(Projection::orthographic);
  auto j = camera_to_json(c);
  j["mesh"] = "something.obj";  // extra keys are ignored
  const Camera d = camera_from_json(j);
  EXPECT_EQ(d.eye, c.eye);
  EXPECT_EQ(d.center, c.center);
  EXPECT_EQ(d.projection, Projection::orthographic);
  EXPECT_EQ(d.width, 800);
  const auto path = test::temp_dir("camera") / "cam.json";
  write_camera(c, path);
  EXPECT_EQ(read_camera(path).eye, c.eye);
}

TEST(Camera, ReadsTheHeaderOfAReferenceSegFile) {
  const auto seg = test::bundled_reference() / "rtsc" / "c3d_cow_v1.seg.xz";
  ASSERT_TRUE(std::filesystem::exists(seg));
  const auto out = test::temp_dir("camera-seg") / "cow.seg";
  const std::string cmd = "xz -dc '" + seg.string() + "' | head -n 1 > '" + out.string() + "'";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const Camera c = read_camera(out);
  EXPECT_GT(c.fov_deg, 40.0);
  EXPECT_LT(c.fov_deg, 41.0);  // the README's 40.733 degrees at d = 3R
  EXPECT_GT((c.eye - c.center).norm(), 0.0);
}

TEST(Camera, BadCamerasAreClearErrors) {
  Camera c = test_camera(Projection::perspective);
  c.up = Vec3::Zero();
  EXPECT_THROW(validate_camera(c), InputError);
  c = test_camera(Projection::perspective);
  c.up = Vec3(0, 0, 1);  // parallel to the viewing direction
  EXPECT_THROW(validate_camera(c), InputError);
  c = test_camera(Projection::perspective);
  c.fov_deg = 180.0;
  EXPECT_THROW(validate_camera(c), InputError);
  c = test_camera(Projection::perspective);
  c.eye = c.center;
  EXPECT_THROW(validate_camera(c), InputError);
  EXPECT_THROW(camera_from_json(nlohmann::json::parse(R"({"eye":[0,0]})")), InputError);
  EXPECT_THROW(camera_from_json(nlohmann::json::parse(R"({"projection":"fisheye"})")), InputError);
  // Image sides that are no int: a float too large for one (fuzz_camera
  // finding, undefined behaviour in the conversion), an int64 that would wrap
  // to 100, a fraction, a string.
  for (const char* bad : {R"({"width": 51311111111111111111111381})", R"({"width": 4294967396})",
                          R"({"height": 512.5})", R"({"height": "512"})", R"({"width": -1e300})"})
    EXPECT_THROW(camera_from_json(nlohmann::json::parse(bad)), InputError) << bad;
  EXPECT_EQ(camera_from_json(nlohmann::json::parse(R"({"width": 640.0})")).width, 640);
}

TEST(Camera, AnatomicalViewsLookFromTheRightSideInLpsAndRas) {
  BoundingBox box;
  box.min = Vec3(-10, -20, -30);
  box.max = Vec3(10, 20, 30);
  // LPS: anterior is -y, left is +x, superior is +z.
  const Camera anterior = anatomical_camera(AnatomicalView::anterior, box, Space::lps);
  EXPECT_LT(anterior.eye.y(), box.center().y());
  EXPECT_NEAR(anterior.eye.x(), 0.0, 1e-9);
  const Camera left = anatomical_camera(AnatomicalView::left, box, Space::lps);
  EXPECT_GT(left.eye.x(), 0.0);
  const Camera left_ras = anatomical_camera(AnatomicalView::left, box, Space::ras);
  EXPECT_LT(left_ras.eye.x(), 0.0);
  const Camera superior = anatomical_camera(AnatomicalView::superior, box, Space::lps);
  EXPECT_GT(superior.eye.z(), 0.0);
  EXPECT_LT(superior.up.y(), 0.0);  // anterior is up on the page
  // The whole box is inside the image.
  for (int i = 0; i < 8; ++i) {
    const Vec3 corner((i & 1) ? box.max.x() : box.min.x(), (i & 2) ? box.max.y() : box.min.y(),
                      (i & 4) ? box.max.z() : box.min.z());
    for (const Camera& c : {anterior, left, superior}) {
      const auto q = project(c, corner);
      EXPECT_GE(q.pixel.x(), 0.0);
      EXPECT_LE(q.pixel.x(), c.width);
      EXPECT_GE(q.pixel.y(), 0.0);
      EXPECT_LE(q.pixel.y(), c.height);
    }
  }
  EXPECT_FALSE(parse_anatomical_view("sideways").has_value());
  EXPECT_EQ(parse_anatomical_view("posterior"), AnatomicalView::posterior);
}

TEST(Camera, RefusesImagesLargerThanAnyCommandDrawsAndNearZeroFieldsOfView) {
  Camera c;
  c.eye = {0, 0, 10};
  c.center = {0, 0, 0};
  c.up = {0, 1, 0};
  c.width = c.height = kMaxImageSide;
  EXPECT_NO_THROW(validate_camera(c));
  c.width = 100000;
  EXPECT_THROW(validate_camera(c), InputError);
  c.width = 512;
  c.fov_deg = 1e-9;  // hatching ran a minute, then crashed (issue 15)
  EXPECT_THROW(validate_camera(c), InputError);
  c.fov_deg = kMinFovDeg;
  EXPECT_NO_THROW(validate_camera(c));
}

TEST(Camera, ACameraFileThatIsNotARegularFileIsBadInput) {
  const auto dir = test::temp_dir("camera-fifo");
  EXPECT_THROW(read_camera(dir), InputError);  // a folder
  EXPECT_THROW(read_camera("/dev/zero"), InputError);
}
