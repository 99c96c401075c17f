// The GL toolkit under OSMesa against values fixed by the test itself: known
// colours, vectors and texel bytes written by shaders and read back exactly.
#include "adapters/osmesa/gl_context.h"
#include "render/gl_program.h"
#include "render/gl_readback.h"
#include "render/gl_texture.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <iostream>

namespace apo::gl {
namespace {

using ::testing::HasSubstr;

constexpr const char* kQuadVertexShader = R"(#version 330 core
layout(location = 0) in vec2 position;
void main() { gl_Position = vec4(position, 0.0, 1.0); }
)";

// Colour bytes as k / 255 so that the RGBA8 conversion is exact; the vector is
// exact in binary floating point.
constexpr const char* kConstantFragmentShader = R"(#version 330 core
layout(location = 0) out vec4 shaded;
layout(location = 1) out vec4 normal;
void main() {
  shaded = vec4(51.0, 102.0, 153.0, 255.0) / 255.0;
  normal = vec4(0.25, -0.5, 0.75, 1.0);
}
)";
constexpr std::uint8_t kShaded[4] = {51, 102, 153, 255};
constexpr float kNormal[4] = {0.25f, -0.5f, 0.75f, 1.0f};

std::unique_ptr<Context> makeContext(int width, int height) {
  auto context = Context::create(width, height);
  EXPECT_TRUE(context.ok()) << context.error().message;
  return context.ok() ? std::move(*context) : nullptr;
}

Program makeProgram(const Api& api, const char* fragmentShader) {
  auto program = buildProgram(api, kQuadVertexShader, fragmentShader);
  EXPECT_TRUE(program.ok()) << program.error().message;
  return program.ok() ? std::move(*program) : Program();
}

// Two triangles covering clip-space x in [-1, 1], y in [yBottom, yTop].
struct Quad {
  Buffer vertices;
  VertexArray layout;
};

Quad makeQuad(const Api& api, float yBottom, float yTop) {
  const float corners[12] = {-1, yBottom, 1, yBottom, 1, yTop, -1, yBottom, 1, yTop, -1, yTop};
  Quad quad{makeBuffer(api), makeVertexArray(api)};
  api.BindVertexArray(quad.layout.id());
  api.BindBuffer(GL_ARRAY_BUFFER, quad.vertices.id());
  api.BufferData(GL_ARRAY_BUFFER, sizeof(corners), corners, GL_STATIC_DRAW);
  api.EnableVertexAttribArray(0);
  api.VertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, nullptr);
  return quad;
}

void draw(const Context& context, const Program& program, const Quad& quad) {
  context.clearTarget({0, 0, 0, 0});
  context.api().UseProgram(program.id());
  context.api().BindVertexArray(quad.layout.id());
  context.api().DrawArrays(GL_TRIANGLES, 0, 6);
}

int glslVersionNumber(const std::string& text) {
  int major = 0, minor = 0;
  if (std::sscanf(text.c_str(), "%d.%d", &major, &minor) != 2) return 0;
  return major * 100 + minor;
}

TEST(GlContext, IsACoreProfileOfAtLeast33WithGlsl330) {
  auto context = makeContext(32, 16);
  ASSERT_TRUE(context);
  const Info& info = context->info();
  std::cout << "asked " << info.requested << "\nGL_VERSION " << info.version << "\nGL_RENDERER " << info.renderer
            << "\nGL_SHADING_LANGUAGE_VERSION " << info.shadingLanguageVersion << "\nGL_MAX_TEXTURE_SIZE "
            << info.maxTextureSize << "\n";
  EXPECT_TRUE(info.coreProfile);
  EXPECT_GE(info.majorVersion * 10 + info.minorVersion, 33);
  EXPECT_GE(glslVersionNumber(info.shadingLanguageVersion), 330);
  EXPECT_THAT(info.version, HasSubstr("Core Profile"));
  EXPECT_GE(info.maxTextureSize, 4096);
}

TEST(GlContext, AMissingOsMesaLibraryIsAnErrorNamingItAndThePackage) {
  auto context = Context::create(16, 16, "libOSMesa-not-installed.so.8");
  ASSERT_FALSE(context.ok());
  EXPECT_EQ(context.error().kind, ErrorKind::Internal);
  EXPECT_THAT(context.error().message, HasSubstr("libOSMesa-not-installed.so.8"));
  EXPECT_THAT(context.error().message, HasSubstr("libosmesa6"));
  // And a library that loads but is not OSMesa.
  auto notOsMesa = Context::create(16, 16, "libm.so.6");
  ASSERT_FALSE(notOsMesa.ok());
  EXPECT_THAT(notOsMesa.error().message, HasSubstr("has no OSMesaCreateContextAttribs"));
}

TEST(GlContext, RefusesAnEmptyTarget) {
  auto context = Context::create(0, 16);
  ASSERT_FALSE(context.ok());
  EXPECT_EQ(context.error().kind, ErrorKind::Usage);
  EXPECT_THAT(context.error().message, HasSubstr("0 x 16"));
}

TEST(GlProgram, ReportsTheFailingStageWithItsLog) {
  auto context = makeContext(8, 8);
  ASSERT_TRUE(context);
  const Api& api = context->api();

  auto fragment = buildProgram(api, kQuadVertexShader, "#version 330 core\nvoid main() { this is not glsl; }\n");
  ASSERT_FALSE(fragment.ok());
  EXPECT_EQ(fragment.error().kind, ErrorKind::Internal);
  EXPECT_THAT(fragment.error().message, HasSubstr("fragment shader failed to compile"));
  EXPECT_THAT(fragment.error().message, HasSubstr("error"));  // Mesa's log: "0:2(20): error: syntax error, ..."
  std::cout << fragment.error().message << "\n";

  auto vertex = buildProgram(api, "#version 330 core\nvoid main() { gl_Position = undeclared; }\n",
                             kConstantFragmentShader);
  ASSERT_FALSE(vertex.ok());
  EXPECT_THAT(vertex.error().message, HasSubstr("vertex shader failed to compile"));
  EXPECT_THAT(vertex.error().message, HasSubstr("undeclared"));

  // Each stage compiles alone; the two disagree on the type of `uv`.
  auto link = buildProgram(api,
                           "#version 330 core\nout vec2 uv;\n"
                           "void main() { uv = vec2(0.0); gl_Position = vec4(0.0); }\n",
                           "#version 330 core\nin vec3 uv;\nout vec4 shaded;\n"
                           "void main() { shaded = vec4(uv, 1.0); }\n");
  ASSERT_FALSE(link.ok());
  EXPECT_THAT(link.error().message, HasSubstr("failed to link"));
  EXPECT_THAT(link.error().message, HasSubstr("uv"));
  std::cout << link.error().message << "\n";
}

// Draws the top half only: row 0 of the read-back image is the top row.
TEST(GlReadback, ReturnsTheWrittenValuesTopRowFirst) {
  const int width = 48, height = 32;
  auto context = makeContext(width, height);
  ASSERT_TRUE(context);
  const Program program = makeProgram(context->api(), kConstantFragmentShader);
  const Quad topHalf = makeQuad(context->api(), 0.0f, 1.0f);
  draw(*context, program, topHalf);

  auto image = readShadedImage(*context);
  auto normals = readNormalBuffer(*context);
  ASSERT_TRUE(image.ok()) << image.error().message;
  ASSERT_TRUE(normals.ok()) << normals.error().message;
  ASSERT_EQ(image->width, width);
  ASSERT_EQ(image->height, height);
  ASSERT_EQ(image->rgba.size(), std::size_t{width * height * 4});
  ASSERT_EQ(normals->data.size(), std::size_t{width * height * 4});
  for (int row = 0; row < height; ++row) {
    const bool top = row < height / 2;
    for (int x = 0; x < width; ++x) {
      const std::size_t pixel = std::size_t(row) * width + x;
      for (int c = 0; c < 4; ++c) {
        ASSERT_EQ(image->rgba[4 * pixel + c], top ? kShaded[c] : 0) << "row " << row << " x " << x << " c " << c;
        ASSERT_EQ(normals->data[4 * pixel + c], top ? kNormal[c] : 0.0f) << "row " << row << " x " << x;
      }
      ASSERT_EQ(normals->covered(pixel), top);
    }
  }
}

// The foundation of "GLSL traversal equals CPU lookup bit for bit": texel
// bytes reach the shader exactly, and a 24-bit payload leaves through the
// float attachment exactly (as float bits with a fixed exponent, never NaN or
// denormal).
TEST(GlTexture, TexelFetchReturnsTheUploadedBytesExactly) {
  const std::uint32_t width = 16, height = 8;
  ApoTexture texture;
  texture.width = width;
  texture.height = height;
  for (std::uint32_t i = 0; i < width * height * 4; ++i) texture.texels.push_back(std::uint8_t(i * 97 + 13));

  auto context = makeContext(width, height);
  ASSERT_TRUE(context);
  const Api& api = context->api();
  const Program program = makeProgram(api, R"(#version 330 core
uniform usampler2D apo;
layout(location = 0) out vec4 shaded;
layout(location = 1) out vec4 normal;
void main() {
  // Texel row y = image row y, counted from the top like the CPU texels.
  ivec2 size = textureSize(apo, 0);
  uvec4 bytes = texelFetch(apo, ivec2(int(gl_FragCoord.x), size.y - 1 - int(gl_FragCoord.y)), 0);
  shaded = vec4(bytes) / 255.0;
  uint payload = bytes.r | (bytes.g << 8) | (bytes.b << 16);
  normal = vec4(uintBitsToFloat(payload | 0x40000000u), float(bytes.a), 0.0, 1.0);
}
)");
  auto uploaded = uploadApoTexture(*context, texture);
  ASSERT_TRUE(uploaded.ok()) << uploaded.error().message;
  api.UseProgram(program.id());
  api.Uniform1i(api.GetUniformLocation(program.id(), "apo"), 0);
  const Quad screen = makeQuad(api, -1.0f, 1.0f);
  draw(*context, program, screen);

  auto image = readShadedImage(*context);
  auto words = readNormalBuffer(*context);
  ASSERT_TRUE(image.ok() && words.ok());
  EXPECT_EQ(image->rgba, texture.texels);
  for (std::size_t pixel = 0; pixel < std::size_t{width * height}; ++pixel) {
    const std::uint8_t* bytes = &texture.texels[4 * pixel];
    std::uint32_t bits = 0;
    std::memcpy(&bits, &words->data[4 * pixel], 4);
    ASSERT_EQ(bits, (bytes[0] | bytes[1] << 8 | bytes[2] << 16) | 0x40000000u) << "pixel " << pixel;
    ASSERT_EQ(words->data[4 * pixel + 1], float(bytes[3])) << "pixel " << pixel;
  }
}

TEST(GlTexture, RefusesATextureOverTheMaximumSizeNamingBothSizes) {
  auto context = makeContext(8, 8);
  ASSERT_TRUE(context);
  const auto maxSize = static_cast<std::uint32_t>(context->info().maxTextureSize);
  // No texels: the size must be refused before they are read.
  ApoTexture tooWide;
  tooWide.width = maxSize + 1;
  tooWide.height = 4;
  ApoTexture tooTall;
  tooTall.width = 4;
  tooTall.height = 3 * maxSize;
  for (const ApoTexture* texture : {&tooWide, &tooTall}) {
    auto uploaded = uploadApoTexture(*context, *texture);
    ASSERT_FALSE(uploaded.ok());
    EXPECT_EQ(uploaded.error().kind, ErrorKind::BadInput);
    EXPECT_THAT(uploaded.error().message,
                HasSubstr(std::to_string(texture->width) + " x " + std::to_string(texture->height)));
    EXPECT_THAT(uploaded.error().message, HasSubstr(std::to_string(maxSize)));
    EXPECT_THAT(uploaded.error().message, HasSubstr("GL_MAX_TEXTURE_SIZE"));
  }
}

TEST(GlReadback, FrameTimerReturnsAPositiveMedian) {
  auto context = makeContext(64, 64);
  ASSERT_TRUE(context);
  const Program program = makeProgram(context->api(), kConstantFragmentShader);
  const Quad screen = makeQuad(context->api(), -1.0f, 1.0f);
  int frames = 0;
  auto median = medianFrameMilliseconds(context->api(), 5, [&] {
    draw(*context, program, screen);
    ++frames;
  });
  ASSERT_TRUE(median.ok()) << median.error().message;
  EXPECT_EQ(frames, 5);
  EXPECT_GT(*median, 0.0);
  EXPECT_LT(*median, 10000.0);
}

TEST(GlContext, ContextsFollowingOneAnotherEachDraw) {
  for (int round = 0; round < 3; ++round) {
    auto context = makeContext(16 + round, 8);
    ASSERT_TRUE(context);
    const Program program = makeProgram(context->api(), kConstantFragmentShader);
    const Quad screen = makeQuad(context->api(), -1.0f, 1.0f);
    draw(*context, program, screen);
    auto image = readShadedImage(*context);
    ASSERT_TRUE(image.ok()) << image.error().message;
    EXPECT_EQ(image->width, 16 + round);
    EXPECT_EQ(image->rgba[0], kShaded[0]) << "round " << round;
    EXPECT_EQ(image->rgba.back(), kShaded[3]) << "round " << round;
  }
}

}  // namespace
}  // namespace apo::gl
