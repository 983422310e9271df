// OSMesa offscreen renderer. Includes GL/OSMesa headers: must never include Open3D headers
// (GLFW's GL headers collide with these).
#include "render/gl_renderer.h"

#include <GL/osmesa.h>  // includes GL/gl.h and GL/glext.h

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <mutex>
#include <opencv2/core.hpp>
#include <sstream>
#include <vector>

#include "core/error.h"

namespace g6d {
namespace {

// Every OSMesa call sequence (a context's creation, a render, a context's destruction)
// holds this lock: one process-wide, not one per context. Debian 12's Mesa (22.3,
// llvmpipe) shares one screen among OSMesa contexts, and two contexts drawing at once on
// two threads segfaulted inside Mesa (g6d-build-templates on 2 threads, about one run in
// 20 under gdb; once in a cold CI run, 2026-11-29). llvmpipe draws on its own threads, so
// the lock costs the template build little (bench/RESULTS.md, "Template renders
// serialized").
std::mutex& OsMesaLock() {
  static std::mutex lock;
  return lock;
}

// Every GL entry point is fetched with OSMesaGetProcAddress instead of being linked: the
// process may also load glvnd's libGL (through Open3D), whose dispatch knows nothing about
// OSMesa contexts; OSMesa's own stubs dispatch to whatever OSMesa context is current.
#define G6D_GL_FUNCTIONS(X)                                    \
  X(decltype(&::glGetString), GetString)                       \
  X(decltype(&::glGetIntegerv), GetIntegerv)                   \
  X(decltype(&::glGetError), GetError)                         \
  X(decltype(&::glViewport), Viewport)                         \
  X(decltype(&::glClear), Clear)                               \
  X(decltype(&::glClearColor), ClearColor)                     \
  X(decltype(&::glClearDepth), ClearDepth)                     \
  X(decltype(&::glEnable), Enable)                             \
  X(decltype(&::glDisable), Disable)                           \
  X(decltype(&::glDepthFunc), DepthFunc)                       \
  X(decltype(&::glReadPixels), ReadPixels)                     \
  X(decltype(&::glReadBuffer), ReadBuffer)                     \
  X(decltype(&::glPixelStorei), PixelStorei)                   \
  X(decltype(&::glDrawElements), DrawElements)                 \
  X(decltype(&::glGenTextures), GenTextures)                   \
  X(decltype(&::glBindTexture), BindTexture)                   \
  X(decltype(&::glTexImage2D), TexImage2D)                     \
  X(decltype(&::glTexParameteri), TexParameteri)               \
  X(decltype(&::glDeleteTextures), DeleteTextures)             \
  X(decltype(&::glFinish), Finish)                             \
  X(PFNGLACTIVETEXTUREPROC, ActiveTexture)                     \
  X(PFNGLCLEARBUFFERFVPROC, ClearBufferfv)                     \
  X(PFNGLDRAWBUFFERSPROC, DrawBuffers)                         \
  X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                 \
  X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                 \
  X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)           \
  X(PFNGLGENBUFFERSPROC, GenBuffers)                           \
  X(PFNGLBINDBUFFERPROC, BindBuffer)                           \
  X(PFNGLBUFFERDATAPROC, BufferData)                           \
  X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                     \
  X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer)         \
  X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray) \
  X(PFNGLCREATESHADERPROC, CreateShader)                       \
  X(PFNGLSHADERSOURCEPROC, ShaderSource)                       \
  X(PFNGLCOMPILESHADERPROC, CompileShader)                     \
  X(PFNGLGETSHADERIVPROC, GetShaderiv)                         \
  X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)               \
  X(PFNGLDELETESHADERPROC, DeleteShader)                       \
  X(PFNGLCREATEPROGRAMPROC, CreateProgram)                     \
  X(PFNGLATTACHSHADERPROC, AttachShader)                       \
  X(PFNGLLINKPROGRAMPROC, LinkProgram)                         \
  X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                       \
  X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)             \
  X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                     \
  X(PFNGLUSEPROGRAMPROC, UseProgram)                           \
  X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)           \
  X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv)               \
  X(PFNGLUNIFORM1IPROC, Uniform1i)                             \
  X(PFNGLUNIFORM1FPROC, Uniform1f)                             \
  X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                 \
  X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                 \
  X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, FramebufferRenderbuffer) \
  X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)   \
  X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)           \
  X(PFNGLGENRENDERBUFFERSPROC, GenRenderbuffers)               \
  X(PFNGLBINDRENDERBUFFERPROC, BindRenderbuffer)               \
  X(PFNGLRENDERBUFFERSTORAGEPROC, RenderbufferStorage)         \
  X(PFNGLDELETERENDERBUFFERSPROC, DeleteRenderbuffers)

struct GlFunctions {
#define G6D_GL_DECLARE(type, name) type name = nullptr;
  G6D_GL_FUNCTIONS(G6D_GL_DECLARE)
#undef G6D_GL_DECLARE

  // Fetches every entry point; throws g6d::Error naming the first one missing.
  void Load() {
#define G6D_GL_LOAD(type, name)                                    \
  name = reinterpret_cast<type>(OSMesaGetProcAddress("gl" #name)); \
  if (name == nullptr) G6D_THROW("GlRenderer: OSMesa lacks GL function gl" #name);
    G6D_GL_FUNCTIONS(G6D_GL_LOAD)
#undef G6D_GL_LOAD
  }
};

// Interleaved vertex layout uploaded to the GPU.
struct GpuVertex {
  float position[3];  // object frame, metres
  float normal[3];    // object frame, unit (zero when the mesh has none)
  float color[3];     // RGB albedo in [0, 1]
  float uv[2];        // texture coordinates, v up (OBJ)
};

// Albedo sources, as the fragment shader's `albedo_source` uniform.
constexpr int kAlbedoGray = 0;
constexpr int kAlbedoVertexColor = 1;
constexpr int kAlbedoTexture = 2;

constexpr const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec3 color;
layout(location = 3) in vec2 uv;
uniform mat4 cam_from_object;
uniform mat4 clip_from_cam;
out vec3 point_in_cam;
out vec3 normal_in_cam;
out vec3 vertex_color;
out vec2 tex_coord;
void main() {
  vec4 p = cam_from_object * vec4(position, 1.0);
  point_in_cam = p.xyz;
  normal_in_cam = mat3(cam_from_object) * normal;
  vertex_color = color;
  tex_coord = uv;
  gl_Position = clip_from_cam * p;
}
)";

// Depth: point_in_cam is interpolated perspective-correctly, and it is affine on the
// triangle, so its z at a fragment is the exact z of the triangle's plane on that pixel's
// ray (up to float rounding). It is written to a float colour target, which avoids the
// precision loss of reading back and linearizing the depth buffer.
constexpr const char* kFragmentShader = R"(#version 330 core
in vec3 point_in_cam;
in vec3 normal_in_cam;
in vec3 vertex_color;
in vec2 tex_coord;
uniform int albedo_source;
uniform int has_normals;
uniform sampler2D albedo_texture;
uniform float default_gray;
uniform float ambient;
uniform float diffuse;
layout(location = 0) out vec4 color_out;
layout(location = 1) out float depth_out;
void main() {
  // Vertex normals when the mesh has them, else the flat face normal.
  vec3 n = has_normals != 0 ? normal_in_cam : cross(dFdx(point_in_cam), dFdy(point_in_cam));
  float n_length = length(n);
  vec3 to_camera = normalize(-point_in_cam);
  // Headlight, two-sided: |n . view|.
  float shade = n_length > 0.0 ? abs(dot(n / n_length, to_camera)) : 1.0;
  vec3 albedo = vec3(default_gray);
  if (albedo_source == 1) {
    albedo = vertex_color;
  } else if (albedo_source == 2) {
    // Row 0 of the uploaded image is t = 0, the image top; OBJ v = 0 is the image bottom.
    albedo = texture(albedo_texture, vec2(tex_coord.x, 1.0 - tex_coord.y)).rgb;
  }
  color_out = vec4(clamp(albedo * (ambient + diffuse * shade), 0.0, 1.0), 1.0);
  depth_out = point_in_cam.z;
}
)";

// Clip coordinates from camera-frame points (x right, y down, z forward, OpenCV), such that
// after the viewport transform (0, 0, width, height) the window x equals the image x
// under K and window y equals height - image y. GL samples fragments at window
// (i + 0.5, j + 0.5), i.e. at image pixel centres (u + 0.5, v + 0.5) with v = height-1-j:
// flipping the read-back rows vertically gives image rows with row 0 at the top.
// z maps near -> -1, far -> +1, and w = z.
Eigen::Matrix4f ClipFromCam(const Camera& camera, double near_m, double far_m) {
  const double w = camera.width;
  const double h = camera.height;
  Eigen::Matrix4d clip = Eigen::Matrix4d::Zero();
  clip(0, 0) = 2.0 * camera.fx / w;
  clip(0, 2) = 2.0 * camera.cx / w - 1.0;
  clip(1, 1) = -2.0 * camera.fy / h;
  clip(1, 2) = 1.0 - 2.0 * camera.cy / h;
  clip(2, 2) = (far_m + near_m) / (far_m - near_m);
  clip(2, 3) = -2.0 * far_m * near_m / (far_m - near_m);
  clip(3, 2) = 1.0;
  return clip.cast<float>();
}

}  // namespace

std::string GlRendererOptions::Check() const {
  std::ostringstream out;
  if (!std::isfinite(near_m) || near_m <= 0.0) {
    out << "near_m must be finite and > 0 (got " << near_m << ")";
  } else if (!std::isfinite(far_m) || far_m <= near_m) {
    out << "far_m must be finite and > near_m (got " << far_m << ", near_m " << near_m << ")";
  } else if (!(ambient >= 0.0 && ambient <= 1.0)) {
    out << "ambient must be in [0, 1] (got " << ambient << ")";
  } else if (!(diffuse >= 0.0 && diffuse <= 1.0)) {
    out << "diffuse must be in [0, 1] (got " << diffuse << ")";
  } else if (!(default_gray >= 0.0f && default_gray <= 1.0f)) {
    out << "default_gray must be in [0, 1] (got " << default_gray << ")";
  }
  return out.str();
}

struct GlRenderer::Impl {
  GlRendererOptions options;
  OSMesaContext context = nullptr;
  // OSMesaMakeCurrent needs a buffer; all drawing goes to the framebuffer object below.
  std::vector<unsigned char> dummy_buffer = std::vector<unsigned char>(4, 0);
  GlFunctions gl;

  GLuint program = 0;
  GLuint vertex_array = 0;
  GLuint vertex_buffer = 0;
  GLuint index_buffer = 0;
  GLuint texture = 0;
  GLsizei index_count = 0;
  int albedo_source = kAlbedoGray;
  bool has_normals = false;

  GLuint framebuffer = 0;
  GLuint color_renderbuffer = 0;       // RGBA8
  GLuint depth_z_renderbuffer = 0;     // R32F, camera-frame z in metres
  GLuint depth_test_renderbuffer = 0;  // DEPTH_COMPONENT32F for the z-test
  int framebuffer_width = 0;
  int framebuffer_height = 0;
  GLint max_size = 0;

  GLint location_cam_from_object = -1;
  GLint location_clip_from_cam = -1;

  void MakeCurrent() {
    if (!OSMesaMakeCurrent(context, dummy_buffer.data(), GL_UNSIGNED_BYTE, 1, 1)) {
      G6D_THROW("GlRenderer: OSMesaMakeCurrent failed");
    }
  }

  // Unbinds whatever context is current on this thread.
  static void ReleaseCurrent() { OSMesaMakeCurrent(nullptr, nullptr, 0, 0, 0); }

  // Makes the context current for one call and unbinds it on the way out, also on a throw.
  // No context stays current on a thread between calls: a thread pool may outlive the
  // renderer, and Mesa touches a thread's current context when that thread binds the next
  // one, so a context destroyed elsewhere while still current there crashed a later renderer.
  class CurrentScope {
   public:
    explicit CurrentScope(Impl* impl) { impl->MakeCurrent(); }
    ~CurrentScope() { ReleaseCurrent(); }
    CurrentScope(const CurrentScope&) = delete;
    CurrentScope& operator=(const CurrentScope&) = delete;
  };

  void CheckGlError(const char* where) {
    const GLenum error = gl.GetError();
    if (error != GL_NO_ERROR) {
      G6D_THROW("GlRenderer: OpenGL error 0x" << std::hex << error << " in " << where);
    }
  }

  GLuint CompileShader(GLenum type, const char* source) {
    const GLuint shader = gl.CreateShader(type);
    gl.ShaderSource(shader, 1, &source, nullptr);
    gl.CompileShader(shader);
    GLint ok = GL_FALSE;
    gl.GetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (ok != GL_TRUE) {
      char log[2048] = {0};
      gl.GetShaderInfoLog(shader, sizeof(log), nullptr, log);
      gl.DeleteShader(shader);
      G6D_THROW("GlRenderer: shader compilation failed: " << log);
    }
    return shader;
  }

  void BuildProgram() {
    const GLuint vertex_shader = CompileShader(GL_VERTEX_SHADER, kVertexShader);
    const GLuint fragment_shader = CompileShader(GL_FRAGMENT_SHADER, kFragmentShader);
    program = gl.CreateProgram();
    gl.AttachShader(program, vertex_shader);
    gl.AttachShader(program, fragment_shader);
    gl.LinkProgram(program);
    gl.DeleteShader(vertex_shader);
    gl.DeleteShader(fragment_shader);
    GLint ok = GL_FALSE;
    gl.GetProgramiv(program, GL_LINK_STATUS, &ok);
    if (ok != GL_TRUE) {
      char log[2048] = {0};
      gl.GetProgramInfoLog(program, sizeof(log), nullptr, log);
      G6D_THROW("GlRenderer: shader link failed: " << log);
    }
    location_cam_from_object = gl.GetUniformLocation(program, "cam_from_object");
    location_clip_from_cam = gl.GetUniformLocation(program, "clip_from_cam");
  }

  void UploadMesh(const Mesh& mesh) {
    const size_t num_vertices = mesh.vertices.size();
    has_normals = mesh.normals.size() == num_vertices && num_vertices > 0;
    const bool has_colors = mesh.colors.size() == num_vertices && num_vertices > 0;
    const bool has_texture = mesh.HasTexture() && mesh.uvs.size() == num_vertices;
    albedo_source = has_texture ? kAlbedoTexture : has_colors ? kAlbedoVertexColor : kAlbedoGray;

    std::vector<GpuVertex> vertices(num_vertices);
    for (size_t i = 0; i < num_vertices; ++i) {
      GpuVertex& vertex = vertices[i];
      for (int k = 0; k < 3; ++k) {
        vertex.position[k] = mesh.vertices[i][k];
        vertex.normal[k] = has_normals ? mesh.normals[i][k] : 0.0f;
        vertex.color[k] = has_colors ? mesh.colors[i][k] : 0.0f;
      }
      for (int k = 0; k < 2; ++k) vertex.uv[k] = has_texture ? mesh.uvs[i][k] : 0.0f;
    }
    std::vector<GLuint> indices;
    indices.reserve(mesh.faces.size() * 3);
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
      for (int k = 0; k < 3; ++k) {
        const int index = mesh.faces[f][k];
        if (index < 0 || static_cast<size_t>(index) >= num_vertices) {
          G6D_THROW("GlRenderer: face " << f << " has vertex index " << index << " outside [0, "
                                        << num_vertices << ")");
        }
        indices.push_back(static_cast<GLuint>(index));
      }
    }
    index_count = static_cast<GLsizei>(indices.size());

    gl.GenVertexArrays(1, &vertex_array);
    gl.BindVertexArray(vertex_array);
    gl.GenBuffers(1, &vertex_buffer);
    gl.BindBuffer(GL_ARRAY_BUFFER, vertex_buffer);
    gl.BufferData(GL_ARRAY_BUFFER, vertices.size() * sizeof(GpuVertex), vertices.data(),
                  GL_STATIC_DRAW);
    gl.GenBuffers(1, &index_buffer);
    gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, index_buffer);
    gl.BufferData(GL_ELEMENT_ARRAY_BUFFER, indices.size() * sizeof(GLuint), indices.data(),
                  GL_STATIC_DRAW);
    const GLsizei stride = sizeof(GpuVertex);
    auto attribute = [&](GLuint location, GLint size, size_t offset) {
      gl.EnableVertexAttribArray(location);
      gl.VertexAttribPointer(location, size, GL_FLOAT, GL_FALSE, stride,
                             reinterpret_cast<const void*>(offset));
    };
    attribute(0, 3, offsetof(GpuVertex, position));
    attribute(1, 3, offsetof(GpuVertex, normal));
    attribute(2, 3, offsetof(GpuVertex, color));
    attribute(3, 2, offsetof(GpuVertex, uv));
    gl.BindVertexArray(0);

    if (has_texture) {
      if (mesh.texture.type() != CV_8UC3) {
        G6D_THROW("GlRenderer: mesh texture must be CV_8UC3 RGB (got type " << mesh.texture.type()
                                                                            << ")");
      }
      GLint max_texture = 0;
      gl.GetIntegerv(GL_MAX_TEXTURE_SIZE, &max_texture);
      if (mesh.texture.cols > max_texture || mesh.texture.rows > max_texture) {
        G6D_THROW("GlRenderer: texture " << mesh.texture.cols << "x" << mesh.texture.rows
                                         << " exceeds GL_MAX_TEXTURE_SIZE " << max_texture);
      }
      const cv::Mat image = mesh.texture.isContinuous() ? mesh.texture : mesh.texture.clone();
      gl.GenTextures(1, &texture);
      gl.ActiveTexture(GL_TEXTURE0);
      gl.BindTexture(GL_TEXTURE_2D, texture);
      gl.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
      gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, image.cols, image.rows, 0, GL_RGB, GL_UNSIGNED_BYTE,
                    image.data);
      gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
      gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    }
    CheckGlError("mesh upload");
  }

  // (Re)creates the framebuffer when the image size changes.
  void EnsureFramebuffer(int width, int height) {
    if (framebuffer != 0 && width == framebuffer_width && height == framebuffer_height) return;
    if (width > max_size || height > max_size) {
      G6D_THROW("GlRenderer: image " << width << "x" << height << " exceeds the OpenGL limit "
                                     << max_size);
    }
    DeleteFramebuffer();
    gl.GenFramebuffers(1, &framebuffer);
    gl.BindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    auto make_renderbuffer = [&](GLenum format, GLenum attachment, GLuint* id) {
      gl.GenRenderbuffers(1, id);
      gl.BindRenderbuffer(GL_RENDERBUFFER, *id);
      gl.RenderbufferStorage(GL_RENDERBUFFER, format, width, height);
      gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, attachment, GL_RENDERBUFFER, *id);
    };
    make_renderbuffer(GL_RGBA8, GL_COLOR_ATTACHMENT0, &color_renderbuffer);
    make_renderbuffer(GL_R32F, GL_COLOR_ATTACHMENT1, &depth_z_renderbuffer);
    make_renderbuffer(GL_DEPTH_COMPONENT32F, GL_DEPTH_ATTACHMENT, &depth_test_renderbuffer);
    const GLenum status = gl.CheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
      G6D_THROW("GlRenderer: framebuffer incomplete (status 0x" << std::hex << status << ")");
    }
    const GLenum draw_buffers[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    gl.DrawBuffers(2, draw_buffers);
    framebuffer_width = width;
    framebuffer_height = height;
    CheckGlError("framebuffer setup");
  }

  void DeleteFramebuffer() {
    if (framebuffer != 0) gl.DeleteFramebuffers(1, &framebuffer);
    GLuint renderbuffers[3] = {color_renderbuffer, depth_z_renderbuffer, depth_test_renderbuffer};
    for (GLuint& id : renderbuffers) {
      if (id != 0) gl.DeleteRenderbuffers(1, &id);
    }
    framebuffer = color_renderbuffer = depth_z_renderbuffer = depth_test_renderbuffer = 0;
    framebuffer_width = framebuffer_height = 0;
  }

  void DeleteAll() {
    if (context == nullptr) return;
    if (OSMesaMakeCurrent(context, dummy_buffer.data(), GL_UNSIGNED_BYTE, 1, 1) &&
        gl.DeleteProgram != nullptr) {
      DeleteFramebuffer();
      if (texture != 0) gl.DeleteTextures(1, &texture);
      if (index_buffer != 0) gl.DeleteBuffers(1, &index_buffer);
      if (vertex_buffer != 0) gl.DeleteBuffers(1, &vertex_buffer);
      if (vertex_array != 0) gl.DeleteVertexArrays(1, &vertex_array);
      if (program != 0) gl.DeleteProgram(program);
    }
    ReleaseCurrent();
    OSMesaDestroyContext(context);
    context = nullptr;
  }
};

GlRenderer::GlRenderer(const Mesh& mesh, const GlRendererOptions& options)
    : impl_(std::make_unique<Impl>()) {
  if (const std::string error = options.Check(); !error.empty()) {
    G6D_THROW("GlRenderer: bad GlRendererOptions: " << error);
  }
  impl_->options = options;
  const std::lock_guard<std::mutex> lock(OsMesaLock());
  // A core 3.3 context with no default depth buffer: everything is drawn into our own
  // framebuffer object, whose float attachments a core profile guarantees.
  const int attributes[] = {OSMESA_FORMAT,
                            OSMESA_RGBA,
                            OSMESA_DEPTH_BITS,
                            0,
                            OSMESA_STENCIL_BITS,
                            0,
                            OSMESA_ACCUM_BITS,
                            0,
                            OSMESA_PROFILE,
                            OSMESA_CORE_PROFILE,
                            OSMESA_CONTEXT_MAJOR_VERSION,
                            3,
                            OSMESA_CONTEXT_MINOR_VERSION,
                            3,
                            0};
  impl_->context = OSMesaCreateContextAttribs(attributes, nullptr);
  if (impl_->context == nullptr) {
    G6D_THROW(
        "GlRenderer: OSMesaCreateContextAttribs failed (need OpenGL 3.3 core from "
        "OSMesa/llvmpipe, Debian package libosmesa6)");
  }
  try {
    Impl::CurrentScope current(impl_.get());
    impl_->gl.Load();
    Impl& impl = *impl_;
    impl.gl.GetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &impl.max_size);
    GLint viewport_dims[2] = {0, 0};
    impl.gl.GetIntegerv(GL_MAX_VIEWPORT_DIMS, viewport_dims);
    impl.max_size = std::min({impl.max_size, viewport_dims[0], viewport_dims[1]});
    impl.BuildProgram();
    impl.UploadMesh(mesh);
    impl.gl.UseProgram(impl.program);
    impl.gl.Uniform1i(impl.gl.GetUniformLocation(impl.program, "albedo_source"),
                      impl.albedo_source);
    impl.gl.Uniform1i(impl.gl.GetUniformLocation(impl.program, "has_normals"),
                      impl.has_normals ? 1 : 0);
    impl.gl.Uniform1i(impl.gl.GetUniformLocation(impl.program, "albedo_texture"), 0);
    impl.gl.Uniform1f(impl.gl.GetUniformLocation(impl.program, "default_gray"),
                      options.default_gray);
    impl.gl.Uniform1f(impl.gl.GetUniformLocation(impl.program, "ambient"),
                      static_cast<float>(options.ambient));
    impl.gl.Uniform1f(impl.gl.GetUniformLocation(impl.program, "diffuse"),
                      static_cast<float>(options.diffuse));
    impl.CheckGlError("program setup");
  } catch (...) {
    impl_->DeleteAll();
    throw;
  }
}

GlRenderer::~GlRenderer() {
  const std::lock_guard<std::mutex> lock(OsMesaLock());
  if (impl_) impl_->DeleteAll();
}

GlImage GlRenderer::Render(const Camera& camera, const Eigen::Isometry3d& cam_from_object) {
  if (const std::string error = camera.Check(); !error.empty()) {
    G6D_THROW("GlRenderer::Render: bad camera: " << error);
  }
  Impl& impl = *impl_;
  const GlFunctions& gl = impl.gl;
  const std::lock_guard<std::mutex> lock(OsMesaLock());
  Impl::CurrentScope current(&impl);
  impl.EnsureFramebuffer(camera.width, camera.height);

  gl.BindFramebuffer(GL_FRAMEBUFFER, impl.framebuffer);
  gl.Viewport(0, 0, camera.width, camera.height);
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_LESS);
  gl.Disable(GL_CULL_FACE);
  const GLfloat black[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  const GLfloat no_depth[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  const GLfloat far_depth = 1.0f;
  gl.ClearBufferfv(GL_COLOR, 0, black);
  gl.ClearBufferfv(GL_COLOR, 1, no_depth);
  gl.ClearBufferfv(GL_DEPTH, 0, &far_depth);

  const Eigen::Matrix4f cam_from_object_f = cam_from_object.matrix().cast<float>();
  const Eigen::Matrix4f clip_from_cam =
      ClipFromCam(camera, impl.options.near_m, impl.options.far_m);
  gl.UseProgram(impl.program);
  // Eigen matrices are column-major, as GL expects.
  gl.UniformMatrix4fv(impl.location_cam_from_object, 1, GL_FALSE, cam_from_object_f.data());
  gl.UniformMatrix4fv(impl.location_clip_from_cam, 1, GL_FALSE, clip_from_cam.data());
  if (impl.texture != 0) {
    gl.ActiveTexture(GL_TEXTURE0);
    gl.BindTexture(GL_TEXTURE_2D, impl.texture);
  }
  gl.BindVertexArray(impl.vertex_array);
  gl.DrawElements(GL_TRIANGLES, impl.index_count, GL_UNSIGNED_INT, nullptr);
  gl.BindVertexArray(0);

  // Read back bottom-up rows, then flip so that row 0 is the image top.
  cv::Mat rgb_up(camera.height, camera.width, CV_8UC3);
  cv::Mat depth_up(camera.height, camera.width, CV_32F);
  gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
  gl.ReadBuffer(GL_COLOR_ATTACHMENT0);
  gl.ReadPixels(0, 0, camera.width, camera.height, GL_RGB, GL_UNSIGNED_BYTE, rgb_up.data);
  gl.ReadBuffer(GL_COLOR_ATTACHMENT1);
  gl.ReadPixels(0, 0, camera.width, camera.height, GL_RED, GL_FLOAT, depth_up.data);
  gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
  impl.CheckGlError("Render");

  GlImage image;
  cv::flip(rgb_up, image.rgb, 0);
  cv::flip(depth_up, image.depth, 0);
  image.mask = image.depth > 0.0f;
  return image;
}

}  // namespace g6d
