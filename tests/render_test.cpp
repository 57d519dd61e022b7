// Tests of the preview renderer: framing, the cosine law, Phong highlights, determinism, PNG.
#include "qjulia/render/render.h"

#include <gtest/gtest.h>
#include <png.h>
#include <sys/wait.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <utility>

#include "io_fixtures.h"
#include "qjulia/base/error.h"
#include "qjulia/io/mesh_io.h"
#include "qjulia/render/contact_sheet.h"
#include "qjulia/render/plot.h"
#include "qjulia/render/text.h"
#include "render_args.h"
#include "test_meshes.h"

namespace qjulia {
namespace {

using fixtures::icosphere;

const std::uint8_t* pixel(const Image& im, int x, int y) {
  return &im.rgb[(static_cast<std::size_t>(y) * im.width + x) * 3];
}

std::size_t count_not_background(const Image& im, const std::array<std::uint8_t, 3>& bg) {
  std::size_t n = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const auto* p = pixel(im, x, y);
      n += p[0] != bg[0] || p[1] != bg[1] || p[2] != bg[2];
    }
  return n;
}

RenderOptions lambert_on_axis(int size) {
  RenderOptions o;
  o.width = o.height = size;
  o.shading = Shading::kLambert;
  o.lights = {{0, 0, 1}};
  o.ambient = 0;
  o.background = {0, 0, 0};
  o.color = {1, 1, 1};
  return o;
}

TEST(Render, UnitSphereIsADiscOfTheFramedRadius) {
  const TriMesh sphere = icosphere(5);
  RenderOptions o;
  o.width = o.height = 400;
  o.background = {255, 0, 255};  // a colour the shading never produces
  o.framing = Framing::kSphere;  // the unit sphere's bounding sphere is the unit sphere
  o.margin = 0.1;
  const Image im = render(sphere, o);
  // kSphere framing: the radius-1 sphere spans (1 - 2 * margin) of the side.
  const double r = 400 * (1 - 2 * o.margin) / 2;
  const double expected = M_PI * r * r;
  EXPECT_NEAR(count_not_background(im, o.background), expected, 0.01 * expected);

  // kBox framing fits the projected extent, which for this sphere is within 0.1% of 2.
  o.framing = Framing::kBox;
  const Image boxed = render(sphere, o);
  EXPECT_NEAR(count_not_background(boxed, o.background), expected, 0.01 * expected);
}

TEST(Render, LambertFollowsTheCosineLaw) {
  const TriMesh sphere = icosphere(6);
  RenderOptions o = lambert_on_axis(512);
  o.framing = Framing::kSphere;
  o.margin = 0;
  const Image im = render(sphere, o);
  // The sphere's centre is at the image centre, radius 256 pixels. The pixel at (x, y) sees the
  // normal (x', y', sqrt(1 - r'^2)); at r' = sin 60 degrees its cosine with the view axis is 0.5.
  const double r = 256;
  auto brightness_at = [&](double rel) {
    // Pixel centres are at i + 0.5; pick the pixel whose centre is nearest to rel * r.
    const int x = static_cast<int>(std::lround(256 + rel * r - 0.5));
    const double actual_rel = (x + 0.5 - 256) / r;
    const double cosine = std::sqrt(1 - actual_rel * actual_rel);
    return std::make_pair(static_cast<double>(pixel(im, x, 255)[0]), cosine);
  };
  const auto [centre, centre_cos] = brightness_at(0);
  const auto [rim, rim_cos] = brightness_at(std::sin(M_PI / 3));
  EXPECT_NEAR(centre, 255 * centre_cos, 1.0);
  EXPECT_NEAR(rim / centre, rim_cos / centre_cos, 0.01);
  EXPECT_NEAR(rim / centre, 0.5, 0.01);
}

TEST(Render, PhongAddsAHighlightLambertHasNot) {
  const TriMesh sphere = icosphere(4);
  RenderOptions o;
  o.width = o.height = 200;
  o.background = {0, 0, 0};
  auto max_brightness = [&](Shading s) {
    o.shading = s;
    const Image im = render(sphere, o);
    int best = 0;
    for (std::size_t i = 0; i < im.rgb.size(); i += 3)
      best = std::max(best, im.rgb[i] + im.rgb[i + 1] + im.rgb[i + 2]);
    return best;
  };
  const int lambert = max_brightness(Shading::kLambert);
  const int phong = max_brightness(Shading::kPhong);
  // Lambert peaks at the surface colour; the specular term adds white on top.
  EXPECT_LE(lambert, std::lround(255 * (o.color[0] + o.color[1] + o.color[2])) + 3);
  EXPECT_GT(phong, lambert + 60);
}

TEST(Render, SimpleShadingShowsFlatFacets) {
  // A level-1 icosphere has 80 faces; flat shading gives each visible face one colour, so the
  // image has few distinct colours, smooth Lambert many.
  const TriMesh sphere = icosphere(1);
  RenderOptions o;
  o.width = o.height = 200;
  auto distinct = [&](Shading s) {
    o.shading = s;
    const Image im = render(sphere, o);
    std::map<std::array<std::uint8_t, 3>, int> colours;
    for (std::size_t i = 0; i < im.rgb.size(); i += 3)
      ++colours[{im.rgb[i], im.rgb[i + 1], im.rgb[i + 2]}];
    return colours.size();
  };
  EXPECT_LE(distinct(Shading::kSimple), 81u);  // 80 faces at most, plus the background
  EXPECT_GT(distinct(Shading::kLambert), 200u);
}

TEST(Render, SameInputGivesSameBytesWhateverTheThreadCount) {
  TriMesh sphere = icosphere(5);
  sphere.colors.resize(sphere.positions.size());
  for (std::size_t v = 0; v < sphere.positions.size(); ++v)
    for (int k = 0; k < 3; ++k) sphere.colors[v][k] = 0.5f + 0.5f * sphere.positions[v][k];
  RenderOptions o;
  o.width = 300;
  o.height = 200;
  o.rotate_deg = {20, 30, 40};
  o.supersample = 2;
  o.lights = {{1, 1, 1}, {-1, 0, 0.5}};
  const Image a = render(sphere, o);
  const Image b = render(sphere, o);
  EXPECT_EQ(a.rgb, b.rgb);
  for (int threads : {1, 2, 3, 7}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    EXPECT_EQ(render(sphere, o).rgb, a.rgb) << threads << " threads";
  }
}

TEST(Render, WithoutNormalsItShadesWithTheAreaWeightedNormalsOfBase) {
  TriMesh bumpy = fixtures::noisy_sphere(3);
  bumpy.normals.clear();
  RenderOptions o;
  o.width = o.height = 160;
  o.rotate_deg = {-25, -35, 0};
  const Image computed = render(bumpy, o);
  compute_normals(bumpy);  // base's one normals routine
  EXPECT_EQ(render(bumpy, o).rgb, computed.rgb);
}

TEST(Render, ACancelledTokenStopsTheRender) {
  CancelToken cancel;
  cancel.request();
  RenderOptions o;
  o.width = o.height = 64;
  o.cancel = &cancel;
  EXPECT_THROW(render(icosphere(2), o), Cancelled);
  cancel.reset();
  EXPECT_NO_THROW(render(icosphere(2), o));
}

TEST(Render, VertexColoursAreUsedUnlessDisabled) {
  TriMesh sphere = icosphere(3);
  sphere.colors.assign(sphere.positions.size(), {1, 0, 0});
  RenderOptions o = lambert_on_axis(100);
  const Image red = render(sphere, o);
  const auto* c = pixel(red, 50, 50);
  EXPECT_GT(c[0], 200);
  EXPECT_EQ(c[1], 0);
  EXPECT_EQ(c[2], 0);
  o.use_vertex_colors = false;
  const Image white = render(sphere, o);
  EXPECT_EQ(pixel(white, 50, 50)[1], pixel(white, 50, 50)[0]);
}

TEST(Render, InvertedNormalsAndWindingStillLightTheVisibleSide) {
  const TriMesh sphere = icosphere(4);
  const RenderOptions o = lambert_on_axis(100);
  const Image reference = render(sphere, o);
  TriMesh inverted = sphere;  // inward normals from a file
  inverted.normals.resize(sphere.positions.size());
  for (std::size_t v = 0; v < sphere.positions.size(); ++v)
    for (int k = 0; k < 3; ++k) inverted.normals[v][k] = -sphere.positions[v][k];
  TriMesh flipped = sphere;  // clockwise faces
  for (auto& t : flipped.triangles) std::swap(t[1], t[2]);
  for (const TriMesh* m : {&inverted, &flipped}) {
    const Image im = render(*m, o);
    EXPECT_NEAR(pixel(im, 50, 50)[0], pixel(reference, 50, 50)[0], 2);
    EXPECT_GT(pixel(im, 50, 50)[0], 240);
  }
}

TEST(Render, RotationTurnsTheView) {
  // A long box along x: seen unrotated it is wide; rotated 90 degrees about z it is tall.
  TriMesh box;
  box.positions = {{-2, -0.5f, -0.5f}, {2, -0.5f, -0.5f}, {2, 0.5f, -0.5f}, {-2, 0.5f, -0.5f},
                   {-2, -0.5f, 0.5f},  {2, -0.5f, 0.5f},  {2, 0.5f, 0.5f},  {-2, 0.5f, 0.5f}};
  box.triangles = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                   {2, 3, 7}, {2, 7, 6}, {1, 2, 6}, {1, 6, 5}, {0, 4, 7}, {0, 7, 3}};
  RenderOptions o;
  o.width = o.height = 100;
  o.margin = 0;
  auto extent = [&](const Image& im) {
    int x0 = im.width, x1 = -1, y0 = im.height, y1 = -1;
    for (int y = 0; y < im.height; ++y)
      for (int x = 0; x < im.width; ++x)
        if (pixel(im, x, y)[0] != 255 || pixel(im, x, y)[1] != 255) {
          x0 = std::min(x0, x);
          x1 = std::max(x1, x);
          y0 = std::min(y0, y);
          y1 = std::max(y1, y);
        }
    return std::make_pair(x1 - x0 + 1, y1 - y0 + 1);
  };
  const auto wide = extent(render(box, o));
  EXPECT_EQ(wide.first, 100);
  EXPECT_NEAR(wide.second, 25, 1);
  o.rotate_deg = {0, 0, 90};
  const auto tall = extent(render(box, o));
  EXPECT_NEAR(tall.first, 25, 1);
  EXPECT_EQ(tall.second, 100);
}

TEST(Render, EmptyMeshGivesTheBackground) {
  RenderOptions o;
  o.width = 10;
  o.height = 5;
  o.background = {1, 2, 3};
  const Image im = render(TriMesh{}, o);
  ASSERT_EQ(im.rgb.size(), 150u);
  EXPECT_EQ(count_not_background(im, o.background), 0u);
}

TEST(Render, BadInputIsRejected) {
  TriMesh sphere = icosphere(0);
  RenderOptions o;
  o.width = 0;
  EXPECT_THROW(render(sphere, o), InvalidInput);
  o = {};
  o.ambient = 1.5;
  EXPECT_THROW(render(sphere, o), InvalidInput);
  o = {};
  o.lights = {{0, 0, 0}};
  EXPECT_THROW(render(sphere, o), InvalidInput);
  o = {};
  TriMesh bad = sphere;
  bad.triangles.push_back({0, 1, 99});
  EXPECT_THROW(render(bad, o), InvalidInput);
  bad = sphere;
  bad.normals.resize(3);
  EXPECT_THROW(render(bad, o), InvalidInput);
  bad = sphere;
  bad.positions[0][1] = NAN;
  EXPECT_THROW(render(bad, o), InvalidInput);
}

/// Reads a PNG with libpng's classic API, independently of read_png().
Image read_with_libpng(const std::string& path) {
  FILE* fp = std::fopen(path.c_str(), "rb");
  if (!fp) return {};
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  Image im;
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    std::fclose(fp);
    return {};
  }
  png_init_io(png, fp);
  png_read_info(png, info);
  EXPECT_EQ(png_get_bit_depth(png, info), 8);
  if (png_get_color_type(png, info) == PNG_COLOR_TYPE_GRAY) png_set_gray_to_rgb(png);
  png_read_update_info(png, info);
  EXPECT_EQ(png_get_color_type(png, info), PNG_COLOR_TYPE_RGB);
  im.width = static_cast<int>(png_get_image_width(png, info));
  im.height = static_cast<int>(png_get_image_height(png, info));
  im.rgb.resize(static_cast<std::size_t>(im.width) * im.height * 3);
  for (int y = 0; y < im.height; ++y)
    png_read_row(png, &im.rgb[static_cast<std::size_t>(y) * im.width * 3], nullptr);
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  std::fclose(fp);
  return im;
}

TEST(Png, WriteReadRoundTripIsExact) {
  Image im;
  im.width = 37;
  im.height = 23;
  im.rgb.resize(37 * 23 * 3);
  for (std::size_t i = 0; i < im.rgb.size(); ++i)
    im.rgb[i] = static_cast<std::uint8_t>(i * 7 + i / 5);
  const auto dir =
      std::filesystem::temp_directory_path() / ("qjulia_render_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "round.png").string();
  write_png(path, im);
  const Image back = read_with_libpng(path);
  EXPECT_EQ(back.width, im.width);
  EXPECT_EQ(back.height, im.height);
  EXPECT_EQ(back.rgb, im.rgb);
  EXPECT_EQ(read_png(path).rgb, im.rgb);
  // An all-grey image is stored as greyscale and reads back as the same RGB bytes.
  Image grey = im;
  for (std::size_t i = 0; i < grey.rgb.size(); i += 3)
    grey.rgb[i + 1] = grey.rgb[i + 2] = grey.rgb[i];
  write_png(path, grey);
  EXPECT_EQ(read_with_libpng(path).rgb, grey.rgb);
  EXPECT_EQ(read_png(path).rgb, grey.rgb);
  EXPECT_LT(std::filesystem::file_size(path), 37u * 23 * 2);
  // No temporary file is left beside the output.
  int files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 1);
  std::filesystem::remove_all(dir);
}

TEST(Png, FailuresThrowAndLeaveNothing) {
  Image im;
  im.width = 2;
  im.height = 2;
  im.rgb.resize(12, 0);
  // A directory that does not exist is bad input (the atomic writer cannot create its file).
  EXPECT_THROW(write_png("/nonexistent-dir/x.png", im), InvalidInput);
  im.rgb.resize(5);
  EXPECT_THROW(write_png("/tmp/never.png", im), InvalidInput);
  EXPECT_THROW(read_png("/nonexistent-dir/x.png"), InvalidInput);
}

TEST(ContactSheet, LaysOutCellsWithCaptions) {
  Image red;
  red.width = 20;
  red.height = 10;
  red.rgb.assign(20 * 10 * 3, 0);
  for (std::size_t i = 0; i < red.rgb.size(); i += 3) red.rgb[i] = 255;
  ContactSheetOptions o;
  o.padding = 4;
  o.text_scale = 1;
  const Image sheet = contact_sheet({{red, "a"}, {red, "b"}, {red, "c"}}, 2, o);
  // Two columns of 20 + 2 * 4; two rows of 4 + 10 + (2 + 9) + 4.
  EXPECT_EQ(sheet.width, 56);
  EXPECT_EQ(sheet.height, 58);
  EXPECT_EQ(pixel(sheet, 4, 4)[0], 255);  // the first image's corner
  EXPECT_EQ(pixel(sheet, 4, 4)[1], 0);
  EXPECT_EQ(pixel(sheet, 3, 3)[1], 255);  // padding
  // The caption row holds dark text pixels, the third slot's image area stays background.
  std::size_t text = 0;
  for (int y = 16; y < 27; ++y)
    for (int x = 0; x < 28; ++x) text += pixel(sheet, x, y)[0] == o.text_color[0];
  EXPECT_GT(text, 3u);
  EXPECT_EQ(pixel(sheet, 28 + 14, 29 + 8)[1], 255);
  EXPECT_EQ(pixel(sheet, 28 + 14, 29 + 17)[1], 255);  // no caption under the empty slot
  EXPECT_THROW(contact_sheet({{red, "a"}}, 0), InvalidInput);
  EXPECT_EQ(contact_sheet({}, 3).width, 0);
}

TEST(ContactSheet, CentresAShortLastRowWhenAsked) {
  Image red = make_image(20, 10, {255, 0, 0});
  ContactSheetOptions o;
  o.padding = 4;
  o.center_last_row = true;
  // Three columns of 28 pixels; the last row's one cell starts one cell width to the right.
  const Image sheet = contact_sheet({{red, ""}, {red, ""}, {red, ""}, {red, ""}}, 3, o);
  ASSERT_EQ(sheet.width, 84);
  ASSERT_EQ(sheet.height, 2 * 18);
  EXPECT_EQ(pixel(sheet, 4, 18 + 4)[1], 255) << "the left slot of the last row stays empty";
  EXPECT_EQ(pixel(sheet, 28 + 4, 18 + 4)[1], 0) << "the one cell is centred";
  EXPECT_EQ(pixel(sheet, 28 + 4, 18 + 4)[0], 255);
  o.center_last_row = false;
  EXPECT_EQ(pixel(contact_sheet({{red, ""}, {red, ""}, {red, ""}, {red, ""}}, 3, o), 4, 22)[1], 0);
}

TEST(Image, FillAndBlitAreClippedToTheImage) {
  Image im = make_image(4, 3, {0, 0, 0});
  fill_rect(im, -5, -5, 2, 1, {9, 9, 9});
  EXPECT_EQ(pixel(im, 0, 0)[0], 9);
  EXPECT_EQ(pixel(im, 1, 0)[0], 9);
  EXPECT_EQ(pixel(im, 2, 0)[0], 0);
  EXPECT_EQ(pixel(im, 0, 1)[0], 0);
  blit(im, make_image(3, 3, {7, 7, 7}), 2, 2);  // only (2, 2) and (3, 2) land inside
  EXPECT_EQ(pixel(im, 2, 2)[0], 7);
  EXPECT_EQ(pixel(im, 3, 2)[0], 7);
  EXPECT_EQ(pixel(im, 1, 2)[0], 0);
  EXPECT_EQ(make_image(0, 0, {1, 2, 3}).rgb.size(), 0u);
  EXPECT_THROW(make_image(-1, 2, {0, 0, 0}), InvalidInput);
}

TEST(Plot, SeriesAreDrawnInTheirColoursOnLogAxes) {
  PlotOptions o;
  o.title = "Distances";
  o.x_label = "iterations";
  o.reference = 1;
  o.reference_label = "one voxel";
  const Rgb red{210, 30, 30}, blue{30, 80, 210};
  const double nan = std::nan("");
  const Image im =
      log_plot({1, 2, 4}, {{"a", red, {1e-2, 1e-1, 1e-1}}, {"b", blue, {nan, nan, nan}}}, o);
  ASSERT_EQ(im.width, 900);
  ASSERT_EQ(im.height, 560);
  // y spans the decades 1e-2..1 (the reference is 1): x = 2 is midway on the log2 axis, 0.1
  // midway on the log10 one (plot area x 90..870, y 50..490).
  const auto* mid = pixel(im, 480, 270);
  EXPECT_EQ((Rgb{mid[0], mid[1], mid[2]}), red);
  std::size_t blue_pixels = 0, red_pixels = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const auto* p = pixel(im, x, y);
      blue_pixels += Rgb{p[0], p[1], p[2]} == blue;
      red_pixels += Rgb{p[0], p[1], p[2]} == red;
    }
  EXPECT_GT(red_pixels, 1000u);
  EXPECT_EQ(blue_pixels, 28u * 5) << "only the legend swatch of a series without points";
  EXPECT_THROW(log_plot({1, 2}, {{"a", red, {1}}}), InvalidInput);
  EXPECT_THROW(log_plot({2, 1}, {}), InvalidInput);
  EXPECT_THROW(log_plot({}, {}), InvalidInput);
}

TEST(Text, GlyphsAreDrawnAndLongCaptionsCut) {
  Image im;
  im.width = 40;
  im.height = 11;
  im.rgb.assign(40 * 11 * 3, 255);
  draw_text(im, 1, 1, "I", {0, 0, 0});
  // 'I' is a 3-pixel bar on top and bottom and a stem in the middle column.
  EXPECT_EQ(pixel(im, 2, 1)[0], 0);
  EXPECT_EQ(pixel(im, 3, 4)[0], 0);
  EXPECT_EQ(pixel(im, 1, 4)[0], 255);
  EXPECT_EQ(text_width("ab", 2), 22);
  EXPECT_EQ(text_height(3), 27);
  EXPECT_EQ(text_width("\xc3\xa9", 1), 5);  // one UTF-8 character, one glyph
  draw_text(im, 20, 1, "p", {0, 0, 0});
  EXPECT_EQ(pixel(im, 20, 9)[0], 0);  // the descender of 'p' below the baseline
  Image cell;
  cell.width = cell.height = 10;
  cell.rgb.assign(300, 0);
  const Image sheet = contact_sheet({{cell, std::string(50, 'x')}}, 1);
  EXPECT_EQ(sheet.width, 10 + 16);  // a long caption does not widen the sheet
}

/// Runs the qjulia CLI with `args`; returns its exit code and puts stderr + stdout in `output`.
int run_cli(const std::string& args, std::string* output = nullptr) {
  const auto log = std::filesystem::temp_directory_path() /
                   ("qjulia_render_cli_" + std::to_string(::getpid()) + ".log");
  const std::string cmd = std::string(QJULIA_CLI) + " " + args + " > " + log.string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  if (output) {
    std::ifstream in(log);
    output->assign(std::istreambuf_iterator<char>(in), {});
  }
  std::error_code ec;
  std::filesystem::remove(log, ec);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class RenderCli : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return dir_.file(name); }
  io_fixtures::TempDir dir_{"render_cli"};  // one per test: ctest runs the tests in parallel
};

TEST_F(RenderCli, RendersAMeshFileWithTheGivenOptions) {
  write_mesh(path("ball.ply"), icosphere(3));
  std::string out;
  ASSERT_EQ(run_cli("render " + path("ball.ply") + " -o " + path("ball.png") +
                        " --size 120x80 --shading lambert --light 0,0,1 --ambient=0 "
                        "--background 0,0,0 --base-color '#ffffff' --rotate 10,-20,30",
                    &out),
            0)
      << out;
  const Image im = read_png(path("ball.png"));
  EXPECT_EQ(im.width, 120);
  EXPECT_EQ(im.height, 80);
  // The centre sees the light head on: white; the corner is background.
  EXPECT_GT(pixel(im, 60, 40)[0], 245);
  EXPECT_EQ(pixel(im, 0, 0)[0], 0);
  // Two views make a contact sheet of two cells side by side.
  ASSERT_EQ(run_cli("render " + path("ball.ply") + " -o " + path("views.png") +
                        " --size 50 --view 0,0,0 --view 90,0,0 --columns 2",
                    &out),
            0)
      << out;
  EXPECT_EQ(read_png(path("views.png")).width, 2 * (50 + 16));
}

TEST_F(RenderCli, ContactSheetOfImagesWithCaptions) {
  Image cell;
  cell.width = 30;
  cell.height = 20;
  cell.rgb.assign(30 * 20 * 3, 0);
  write_png(path("a.png"), cell);
  write_png(path("b.png"), cell);
  std::string out;
  ASSERT_EQ(run_cli("render " + path("a.png") + " " + path("b.png") + " " + path("a.png") +
                        " --columns 3 --caption first -o " + path("sheet.png"),
                    &out),
            0)
      << out;
  const Image sheet = read_png(path("sheet.png"));
  EXPECT_EQ(sheet.width, 3 * (30 + 16));
  // "first" at double size (58 pixels) would not fit a 30-pixel cell: single-size captions.
  EXPECT_EQ(sheet.height, 8 + 20 + 4 + 9 + 8);
  ASSERT_EQ(run_cli("render " + path("a.png") + " " + path("b.png") + " --caption ab -o " +
                        path("sheet2.png"),
                    &out),
            0)
      << out;
  EXPECT_EQ(read_png(path("sheet2.png")).height, 8 + 20 + 4 + 18 + 8);  // "ab" fits: double
}

TEST_F(RenderCli, BadInputExitsWithCodeTwoAndWritesNothing) {
  Image cell;
  cell.width = cell.height = 4;
  cell.rgb.assign(48, 0);
  write_png(path("a.png"), cell);
  std::string out;
  EXPECT_EQ(run_cli("render " + path("a.png") + " -o " + path("x.jpg"), &out), 2) << out;
  EXPECT_EQ(run_cli("render " + path("a.png"), &out), 2) << out;
  EXPECT_EQ(run_cli("render -o " + path("x.png"), &out), 2) << out;
  EXPECT_EQ(run_cli("render " + path("a.png") + " -o " + path("x.png") + " --shading glossy", &out),
            2)
      << out;
  EXPECT_NE(out.find("--shading"), std::string::npos) << out;
  EXPECT_EQ(run_cli("render " + path("a.png") + " -o " + path("x.png") + " --size 0x5", &out), 2);
  EXPECT_EQ(run_cli("render " + path("a.png") + " -o " + path("x.png") + " --background red", &out),
            2);
  EXPECT_EQ(run_cli("render " + path("a.png") + " -o " + path("x.png") + " --ambient 2", &out), 2);
  EXPECT_EQ(run_cli("render " + path("missing.ply") + " -o " + path("x.png"), &out), 2) << out;
  EXPECT_NE(out.find("missing.ply': no such file"), std::string::npos) << out;
  // A file that exists but is no mesh file is not called missing.
  EXPECT_EQ(run_cli("render /dev/null -o " + path("x.png"), &out), 2) << out;
  EXPECT_NE(out.find("'/dev/null': is not a regular file"), std::string::npos) << out;
  std::filesystem::create_directory(path("d.ply"));
  EXPECT_EQ(run_cli("render " + path("d.ply") + " -o " + path("x.png"), &out), 2) << out;
  EXPECT_NE(out.find("d.ply': is a directory, not a mesh file"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(path("x.png")));
  // The preview of `mesh` is a PNG too: another extension is refused before the work.
  EXPECT_EQ(run_cli("mesh --preset unit-ball --resolution 16 --quiet -o " + path("m.ply") +
                        " --preview " + path("m.jpg"),
                    &out),
            2);
  EXPECT_NE(out.find("--preview: '" + path("m.jpg") + "' must end in .png"), std::string::npos)
      << out;
  EXPECT_FALSE(std::filesystem::exists(path("m.ply")));
  EXPECT_FALSE(std::filesystem::exists(path("m.jpg")));
  EXPECT_EQ(run_cli("render --help", &out), 0);
  EXPECT_NE(out.find("--shading"), std::string::npos);
}

TEST(RenderArgs, FlagsBecomeOptionsWithAnOptionalPrefix) {
  using namespace cli;
  const auto specs = render_option_specs("preview-");
  const ParsedArgs args = parse_args({"--preview-shading",
                                      "simple",
                                      "--preview-light",
                                      "1,0,0",
                                      "--preview-light=0,1,0",
                                      "--preview-rotate",
                                      "-10,20,-30",
                                      "--preview-size",
                                      "640x480",
                                      "--preview-background",
                                      "#0a0B0c",
                                      "--preview-base-color",
                                      "255,0,51",
                                      "--preview-ambient",
                                      "0.3",
                                      "--preview-no-vertex-colors",
                                      "--preview-framing",
                                      "sphere",
                                      "--preview-supersample",
                                      "2"},
                                     specs, "mesh");
  const RenderOptions o = render_options_from_args(args, "preview-");
  EXPECT_EQ(o.shading, Shading::kSimple);
  ASSERT_EQ(o.lights.size(), 2u);
  EXPECT_EQ(o.lights[1][1], 1.0);
  EXPECT_EQ(o.rotate_deg[0], -10.0);
  EXPECT_EQ(o.rotate_deg[2], -30.0);
  EXPECT_EQ(o.width, 640);
  EXPECT_EQ(o.height, 480);
  EXPECT_EQ(o.background, (std::array<std::uint8_t, 3>{10, 11, 12}));
  EXPECT_DOUBLE_EQ(o.color[0], 1.0);
  EXPECT_DOUBLE_EQ(o.color[2], 0.2);
  EXPECT_DOUBLE_EQ(o.ambient, 0.3);
  EXPECT_FALSE(o.use_vertex_colors);
  EXPECT_EQ(o.framing, Framing::kSphere);
  EXPECT_EQ(o.supersample, 2);
  // Without flags: the library's defaults.
  const RenderOptions d = render_options_from_args(parse_args({}, specs, "mesh"), "preview-");
  EXPECT_EQ(d.width, RenderOptions{}.width);
  EXPECT_EQ(d.shading, RenderOptions{}.shading);
}

TEST(RenderArgs, BadValuesNameTheFlag) {
  using namespace cli;
  auto fails_naming = [](const std::vector<std::string>& tokens, const std::string& flag) {
    try {
      render_options_from_args(parse_args(tokens, render_option_specs(), "render"));
    } catch (const InvalidInput& e) {
      return std::string(e.what()).find(flag) != std::string::npos;
    }
    return false;
  };
  EXPECT_TRUE(fails_naming({"--shading", "glossy"}, "--shading"));
  EXPECT_TRUE(fails_naming({"--size", "12y4"}, "--size"));
  EXPECT_TRUE(fails_naming({"--size", "0x4"}, "--size"));
  EXPECT_TRUE(fails_naming({"--background", "#12345"}, "--background"));
  EXPECT_TRUE(fails_naming({"--background", "256,0,0"}, "--background"));
  EXPECT_TRUE(fails_naming({"--light", "1,2"}, "--light"));
  EXPECT_TRUE(fails_naming({"--rotate", "x,0,0"}, "--rotate"));
  EXPECT_TRUE(fails_naming({"--framing", "tight"}, "--framing"));
  EXPECT_TRUE(fails_naming({"--supersample", "9"}, "--supersample"));
  // Ranges are checked at the door, before any mesh is read or made.
  EXPECT_TRUE(fails_naming({"--ambient", "2"}, "--ambient"));
  EXPECT_TRUE(fails_naming({"--specular", "-0.1"}, "--specular"));
  EXPECT_TRUE(fails_naming({"--margin", "0.5"}, "--margin"));
  EXPECT_TRUE(fails_naming({"--light", "0,0,0"}, "--light"));
  EXPECT_TRUE(fails_naming({"--shininess", "0"}, "--shininess"));
  EXPECT_TRUE(fails_naming({"--size", "16384", "--supersample", "4"}, "--size"));
  EXPECT_EQ(parse_image_size("300", "s"), std::make_pair(300, 300));
  EXPECT_EQ(parse_color("#fff", "c"), (std::array<std::uint8_t, 3>{255, 255, 255}));
}

}  // namespace
}  // namespace qjulia
