// Mesh files: OBJ and PLY readers of our own.
//
// Why not Debian's tinyobjloader (2.0.0rc10): it parses coordinates into float (the scene model
// drops zero-area triangles in double, after the transform), takes "nan" or a malformed number
// for 0 without a word, reports a face of fewer than 3 vertices as a warning with no line, and
// keeps a copy of every corner in its own index structures. Debian 12 packages no PLY library
// (neither tinyply nor rply). Both readers below are small, read the text once from the bounded
// reader, and name the line (OBJ, ascii PLY) or the element (binary PLY) of any bad input.
#include "lancer/mesh_io.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>

#include "lancer/error.hpp"

namespace lancer {

namespace {

[[noreturn]] void bad(const std::string& where, const std::string& what) {
  throw InputError(where + ": " + what);
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

// A cursor over one line of text.
struct Line {
  const char* p;
  const char* end;

  void skip_space() {
    while (p < end && is_space(*p)) ++p;
  }
  bool at_end() {
    skip_space();
    return p == end;
  }
  // The next whitespace-separated token (empty at the end).
  std::string_view token() {
    skip_space();
    const char* b = p;
    while (p < end && !is_space(*p)) ++p;
    return {b, std::size_t(p - b)};
  }
};

// A number as text, strictly: the whole token, finite.
bool parse_double(std::string_view tok, double& v) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  const auto r = std::from_chars(tok.data(), tok.data() + tok.size(), v);
  return r.ec == std::errc() && r.ptr == tok.data() + tok.size();
}
bool parse_long(std::string_view tok, long long& v) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  const auto r = std::from_chars(tok.data(), tok.data() + tok.size(), v);
  return r.ec == std::errc() && r.ptr == tok.data() + tok.size();
}

std::string shown_token(std::string_view tok) {
  std::string s(tok.substr(0, 40));
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  return tok.size() > 40 ? s + "..." : s;
}

// `where()` names the place, called only for a message: no string per line read.
template <class Where>
Vec3<double> read_xyz(Line& line, const Where& where, const char* what) {
  double c[3];
  for (double& v : c) {
    const std::string_view tok = line.token();
    if (tok.empty()) bad(where(), std::string(what) + " needs 3 coordinates");
    if (!parse_double(tok, v)) bad(where(), "'" + shown_token(tok) + "' is not a number");
    if (!std::isfinite(v)) bad(where(), std::string(what) + " coordinate is not finite");
  }
  return {c[0], c[1], c[2]};
}

// An OBJ index (1-based, or negative: counted back from the last one read) to 0-based.
template <class Where>
std::uint32_t obj_index(std::string_view tok, std::size_t count, const Where& where,
                        const char* what) {
  long long i;
  if (!parse_long(tok, i)) bad(where(), std::string(what) + " index '" + shown_token(tok) + "'");
  const long long n = static_cast<long long>(count);
  const long long k = i < 0 ? n + i : i - 1;
  if (i == 0 || k < 0 || k >= n)
    bad(where(), std::string(what) + " index " + std::to_string(i) + " out of range (" +
                     (n == 0 ? std::string("none read yet")
                             : "1 to " + std::to_string(n) + " or -1 to -" + std::to_string(n)) +
                     ")");
  return static_cast<std::uint32_t>(k);
}

template <class Where>
void check_room(const MeshFile& m, const Where& where) {
  if (m.indices.size() / 3 >= kMaxTriangles)
    bad(where(), "more than " + std::to_string(kMaxTriangles) + " triangles");
}

// Appends face corners (position and normal indices) as a fan.
template <class Where>
void add_fan(MeshFile& m, const std::vector<std::uint32_t>& v, const std::vector<std::uint32_t>& n,
             bool normals, const Where& where) {
  for (std::size_t i = 1; i + 1 < v.size(); ++i) {
    check_room(m, where);
    for (std::size_t k : {std::size_t(0), i, i + 1}) {
      m.indices.push_back(v[k]);
      if (normals) m.normal_indices.push_back(n[k]);
    }
  }
}

}  // namespace

MeshFile parse_obj(const std::string& text, const std::string& shown) {
  MeshFile m;
  std::vector<std::uint32_t> face, face_n;
  bool any_normal_ref = false;
  std::size_t line_no = 0;
  const char* p = text.data();
  const char* const end = p + text.size();
  while (p < end) {
    const char* eol = static_cast<const char*>(std::memchr(p, '\n', std::size_t(end - p)));
    if (!eol) eol = end;
    Line line{p, eol};
    p = eol + (eol < end);
    ++line_no;
    const std::string_view kw = line.token();
    if (kw.empty() || kw.front() == '#') continue;
    if (kw != "v" && kw != "vn" && kw != "f") continue;  // materials, groups, textures: ignored
    auto where = [&] { return shown + ":" + std::to_string(line_no); };
    if (kw == "v") {
      m.positions.push_back(read_xyz(line, where, "vertex"));
    } else if (kw == "vn") {
      m.normals.push_back(read_xyz(line, where, "normal"));
    } else {
      face.clear(), face_n.clear();
      bool with_normals = false;
      for (std::string_view tok = line.token(); !tok.empty(); tok = line.token()) {
        const std::size_t s1 = tok.find('/');
        face.push_back(obj_index(tok.substr(0, s1), m.positions.size(), where, "vertex"));
        std::uint32_t n = MeshFile::kNoNormal;
        if (s1 != std::string_view::npos) {
          const std::size_t s2 = tok.find('/', s1 + 1);
          if (s2 != std::string_view::npos && s2 + 1 < tok.size()) {
            n = obj_index(tok.substr(s2 + 1), m.normals.size(), where, "normal");
            with_normals = true;
          }
        }
        face_n.push_back(n);
      }
      if (face.size() < 3)
        bad(where(), "a face needs at least 3 vertices, not " + std::to_string(face.size()));
      if (with_normals && !any_normal_ref) {
        // The first face with normals: the earlier corners had none.
        any_normal_ref = true;
        m.normal_indices.assign(m.indices.size(), MeshFile::kNoNormal);
      }
      add_fan(m, face, face_n, any_normal_ref, where);
    }
  }
  return m;
}

namespace {

// PLY scalar types.
enum class PlyType { i8, u8, i16, u16, i32, u32, f32, f64 };

bool ply_type(std::string_view s, PlyType& t) {
  static const std::pair<const char*, PlyType> names[] = {
      {"char", PlyType::i8},    {"int8", PlyType::i8},     {"uchar", PlyType::u8},
      {"uint8", PlyType::u8},   {"short", PlyType::i16},   {"int16", PlyType::i16},
      {"ushort", PlyType::u16}, {"uint16", PlyType::u16},  {"int", PlyType::i32},
      {"int32", PlyType::i32},  {"uint", PlyType::u32},    {"uint32", PlyType::u32},
      {"float", PlyType::f32},  {"float32", PlyType::f32}, {"double", PlyType::f64},
      {"float64", PlyType::f64}};
  for (const auto& [name, type] : names)
    if (s == name) return t = type, true;
  return false;
}

std::size_t ply_size(PlyType t) {
  switch (t) {
    case PlyType::i8:
    case PlyType::u8:
      return 1;
    case PlyType::i16:
    case PlyType::u16:
      return 2;
    case PlyType::i32:
    case PlyType::u32:
    case PlyType::f32:
      return 4;
    case PlyType::f64:
      return 8;
  }
  return 1;
}

bool ply_integral(PlyType t) { return t != PlyType::f32 && t != PlyType::f64; }

struct PlyProperty {
  std::string name;
  bool list = false;
  PlyType count_type = PlyType::u8, type = PlyType::f32;
};
struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> props;
};

// Values of a PLY body, ascii or binary little-endian, with every read bounded.
class PlyBody {
 public:
  PlyBody(const std::string& text, std::size_t at, bool ascii, std::size_t line,
          const std::string& shown)
      : p_(text.data() + at),
        end_(text.data() + text.size()),
        ascii_(ascii),
        line_(line),
        shown_(shown) {}

  void set_place(const std::string& element, std::size_t index) {
    element_ = &element;
    index_ = index;
  }
  std::string where() const {
    if (ascii_) return shown_ + ":" + std::to_string(line_);
    if (!element_) return shown_;
    return shown_ + ": " + *element_ + " " + std::to_string(index_);
  }
  // The bytes left, for a count's plausibility (binary: every element takes at least one byte).
  std::size_t left() const { return std::size_t(end_ - p_); }

  double value(PlyType t) {
    if (ascii_) {
      const std::string_view tok = next_token();
      double v;
      if (!parse_double(tok, v)) bad(where(), "'" + shown_token(tok) + "' is not a number");
      if (ply_integral(t) && v != std::floor(v))
        bad(where(), "'" + shown_token(tok) + "' is not an integer");
      return v;
    }
    const std::size_t n = ply_size(t);
    if (left() < n) bad(where(), "file ends inside the element (truncated)");
    unsigned char b[8];
    std::memcpy(b, p_, n);
    p_ += n;
    auto u = [&](int k) { return std::uint64_t(b[k]); };
    switch (t) {
      case PlyType::i8:
        return double(std::int8_t(b[0]));
      case PlyType::u8:
        return double(b[0]);
      case PlyType::i16:
        return double(std::int16_t(u(0) | u(1) << 8));
      case PlyType::u16:
        return double(std::uint16_t(u(0) | u(1) << 8));
      case PlyType::i32:
        return double(std::int32_t(std::uint32_t(u(0) | u(1) << 8 | u(2) << 16 | u(3) << 24)));
      case PlyType::u32:
        return double(std::uint32_t(u(0) | u(1) << 8 | u(2) << 16 | u(3) << 24));
      case PlyType::f32: {
        float f;
        std::memcpy(&f, b, 4);
        return double(f);
      }
      case PlyType::f64: {
        double d;
        std::memcpy(&d, b, 8);
        return d;
      }
    }
    return 0;
  }
  // Ascii: each element is one line; the next starts after its end.
  void end_element() {
    if (!ascii_) return;
    while (p_ < end_ && is_space(*p_)) ++p_;
    if (p_ < end_ && *p_ != '\n') bad(where(), "more values than the header declares");
    if (p_ < end_) ++p_, ++line_;
  }

 private:
  std::string_view next_token() {
    while (p_ < end_ && is_space(*p_)) ++p_;
    if (p_ == end_ || *p_ == '\n') bad(where(), "fewer values than the header declares");
    const char* b = p_;
    while (p_ < end_ && !is_space(*p_) && *p_ != '\n') ++p_;
    return {b, std::size_t(p_ - b)};
  }

  const char* p_;
  const char* end_;
  bool ascii_;
  std::size_t line_;
  const std::string& shown_;
  const std::string* element_ = nullptr;
  std::size_t index_ = 0;
};

// The header up to end_header: format and elements. Sets `body` to the first byte after it.
std::vector<PlyElement> ply_header(const std::string& text, const std::string& shown, bool& ascii,
                                   std::size_t& body, std::size_t& line_no) {
  std::vector<PlyElement> elements;
  const char* p = text.data();
  const char* const end = p + text.size();
  bool format = false;
  line_no = 0;
  for (;;) {
    if (p == end) bad(shown, "PLY header without end_header");
    const char* eol = static_cast<const char*>(std::memchr(p, '\n', std::size_t(end - p)));
    if (!eol) bad(shown, "PLY header without end_header");
    Line line{p, eol};
    p = eol + 1;
    ++line_no;
    const std::string where = shown + ":" + std::to_string(line_no);
    const std::string_view kw = line.token();
    if (line_no == 1) {
      if (kw != "ply") bad(where, "not a PLY file (no 'ply' line)");
      continue;
    }
    if (kw == "end_header") break;
    if (kw == "comment" || kw == "obj_info" || kw.empty()) continue;
    if (kw == "format") {
      const std::string_view f = line.token();
      if (f == "ascii") {
        ascii = true;
      } else if (f == "binary_little_endian") {
        ascii = false;
      } else {
        bad(where, "format '" + shown_token(f) + "' not read (ascii or binary_little_endian)");
      }
      format = true;
    } else if (kw == "element") {
      PlyElement e;
      e.name = std::string(line.token());
      long long n;
      const std::string_view tok = line.token();
      if (!parse_long(tok, n) || n < 0) bad(where, "element count '" + shown_token(tok) + "'");
      if (std::size_t(n) > text.size())
        bad(where, "element count " + std::to_string(n) + " exceeds the file's size");
      e.count = std::size_t(n);
      elements.push_back(std::move(e));
    } else if (kw == "property") {
      if (elements.empty()) bad(where, "property before any element");
      PlyProperty prop;
      std::string_view t = line.token();
      if (t == "list") {
        prop.list = true;
        if (!ply_type(line.token(), prop.count_type) || !ply_integral(prop.count_type))
          bad(where, "list count type must be an integer type");
        t = line.token();
      }
      if (!ply_type(t, prop.type)) bad(where, "property type '" + shown_token(t) + "'");
      prop.name = std::string(line.token());
      elements.back().props.push_back(std::move(prop));
    } else {
      bad(where, "unknown header line '" + shown_token(kw) + "'");
    }
  }
  if (!format) bad(shown, "PLY header without a format line");
  body = std::size_t(p - text.data());
  return elements;
}

// One vertex or face element's values into the mesh.
void ply_vertices(PlyBody& b, const PlyElement& e, MeshFile& m) {
  b.set_place(e.name, 0);
  int slot[6] = {-1, -1, -1, -1, -1, -1};
  static const char* names[6] = {"x", "y", "z", "nx", "ny", "nz"};
  for (std::size_t k = 0; k < e.props.size(); ++k)
    for (int c = 0; c < 6; ++c)
      if (!e.props[k].list && e.props[k].name == names[c]) slot[c] = int(k);
  if (slot[0] < 0 || slot[1] < 0 || slot[2] < 0) bad(b.where(), "vertex element without x, y, z");
  const bool normals = slot[3] >= 0 && slot[4] >= 0 && slot[5] >= 0;
  m.positions.reserve(e.count);
  if (normals) m.normals.reserve(e.count);
  for (std::size_t i = 0; i < e.count; ++i) {
    b.set_place(e.name, i);
    double v[6] = {0, 0, 0, 0, 0, 0};
    for (std::size_t k = 0; k < e.props.size(); ++k) {
      const PlyProperty& prop = e.props[k];
      if (prop.list) {
        const double n = b.value(prop.count_type);
        if (n < 0) bad(b.where(), "negative list length");
        for (double j = 0; j < n; ++j) b.value(prop.type);
        continue;
      }
      const double x = b.value(prop.type);
      for (int c = 0; c < 6; ++c)
        if (slot[c] == int(k)) v[c] = x;
    }
    for (int c = 0; c < (normals ? 6 : 3); ++c)
      if (!std::isfinite(v[c])) bad(b.where(), std::string(names[c]) + " is not finite");
    m.positions.push_back({v[0], v[1], v[2]});
    if (normals) m.normals.push_back({v[3], v[4], v[5]});
    b.end_element();
  }
}

void ply_faces(PlyBody& b, const PlyElement& e, MeshFile& m, std::size_t vertices) {
  b.set_place(e.name, 0);
  int slot = -1;
  for (std::size_t k = 0; k < e.props.size(); ++k)
    if (e.props[k].list &&
        (e.props[k].name == "vertex_indices" || e.props[k].name == "vertex_index"))
      slot = int(k);
  if (slot < 0) bad(b.where(), "face element without a vertex_indices list");
  if (!ply_integral(e.props[std::size_t(slot)].type))
    bad(b.where(), "vertex_indices must be of an integer type");
  std::vector<std::uint32_t> face;
  // Triangles are the common case. A face takes at least 4 bytes (binary: a count and three
  // one-byte indices; ascii more), so the reservation stays within 3 times what is left to read.
  m.indices.reserve(3 * std::min({e.count, b.left() / 4, kMaxTriangles}));
  for (std::size_t i = 0; i < e.count; ++i) {
    b.set_place(e.name, i);
    for (std::size_t k = 0; k < e.props.size(); ++k) {
      const PlyProperty& prop = e.props[k];
      const double n = prop.list ? b.value(prop.count_type) : 1;
      if (n < 0) bad(b.where(), "negative list length");
      if (int(k) == slot) face.clear();
      for (double j = 0; j < n; ++j) {
        const double v = b.value(prop.type);
        if (int(k) != slot) continue;
        if (v < 0 || v >= double(vertices))
          bad(b.where(), "vertex index " + std::to_string((long long)v) + " out of range (0 to " +
                             std::to_string((long long)vertices - 1) + ")");
        face.push_back(std::uint32_t(v));
      }
    }
    if (face.size() < 3)
      bad(b.where(), "a face needs at least 3 vertices, not " + std::to_string(face.size()));
    add_fan(m, face, face, false, [&] { return b.where(); });
    b.end_element();
  }
}

}  // namespace

MeshFile parse_ply(const std::string& text, const std::string& shown) {
  bool ascii = true;
  std::size_t body = 0, line_no = 0;
  const std::vector<PlyElement> elements = ply_header(text, shown, ascii, body, line_no);
  MeshFile m;
  PlyBody b(text, body, ascii, line_no + 1, shown);
  bool have_vertices = false, have_faces = false;
  for (const PlyElement& e : elements) {
    if (!ascii && e.count > b.left()) {
      b.set_place(e.name, 0);
      bad(b.where(),
          "file ends before " + std::to_string(e.count) + " " + e.name + " elements (truncated)");
    }
    if (e.name == "vertex" && !have_vertices) {
      ply_vertices(b, e, m);
      have_vertices = true;
    } else if (e.name == "face" && !have_faces) {
      if (!have_vertices) {
        b.set_place(e.name, 0);
        bad(b.where(), "face element before the vertex element");
      }
      ply_faces(b, e, m, m.positions.size());
      have_faces = true;
    } else {
      // Any other element is read and dropped.
      for (std::size_t i = 0; i < e.count; ++i) {
        b.set_place(e.name, i);
        for (const PlyProperty& prop : e.props) {
          const double n = prop.list ? b.value(prop.count_type) : 1;
          if (n < 0) bad(b.where(), "negative list length");
          for (double j = 0; j < n; ++j) b.value(prop.type);
        }
        b.end_element();
      }
    }
  }
  if (!have_vertices) bad(shown, "no vertex element");
  if (!m.normals.empty()) m.normal_indices = m.indices;  // a PLY normal belongs to its vertex
  return m;
}

namespace {

// sin and cos of an angle in degrees, exact at multiples of 90 (a quarter turn gives 0, not
// 6e-17).
void sin_cos_degrees(double degrees, double& s, double& c) {
  const double r = std::fmod(degrees, 360.0);
  if (r == std::floor(r / 90) * 90) {
    const int q = ((int(r / 90) % 4) + 4) % 4;
    static const double sq[4] = {0, 1, 0, -1}, cq[4] = {1, 0, -1, 0};
    s = sq[q], c = cq[q];
    return;
  }
  const double rad = r * (M_PI / 180.0);
  s = std::sin(rad), c = std::cos(rad);
}

// M = Rz Ry Rx, right-handed rotations about the world axes, x first.
struct Rotation {
  double m[3][3];
  explicit Rotation(const Vec3<double>& deg) {
    double sx, cx, sy, cy, sz, cz;
    sin_cos_degrees(deg.x, sx, cx);
    sin_cos_degrees(deg.y, sy, cy);
    sin_cos_degrees(deg.z, sz, cz);
    const double rx[3][3] = {{1, 0, 0}, {0, cx, -sx}, {0, sx, cx}};
    const double ry[3][3] = {{cy, 0, sy}, {0, 1, 0}, {-sy, 0, cy}};
    const double rz[3][3] = {{cz, -sz, 0}, {sz, cz, 0}, {0, 0, 1}};
    double zy[3][3];
    mul(rz, ry, zy);
    mul(zy, rx, m);
  }
  static void mul(const double a[3][3], const double b[3][3], double out[3][3]) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        out[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
  }
  Vec3<double> apply(const Vec3<double>& v) const {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
  }
};

Vec3<double> unit_or_zero(const Vec3<double>& v) {
  const double len = length(v);
  return len > 0 && std::isfinite(len) ? v / len : Vec3<double>{0, 0, 0};
}

}  // namespace

void place_mesh(MeshFile&& file, const MeshTransform& t, bool smooth, const std::string& shown,
                Mesh& out) {
  const Rotation rot(t.rotate);
  out.vertices.resize(file.positions.size());
  for (std::size_t i = 0; i < file.positions.size(); ++i) {
    const Vec3<double>& p = file.positions[i];
    out.vertices[i] = t.translate + rot.apply({t.scale.x * p.x, t.scale.y * p.y, t.scale.z * p.z});
  }
  std::vector<Vec3<double>>().swap(file.positions);
  // Zero-area triangles (an exactly zero cross product, in double, after the transform) go.
  const std::size_t n = file.indices.size() / 3;
  const bool file_normals = !file.normal_indices.empty();
  std::size_t kept = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t* v = &file.indices[3 * k];
    const Vec3<double> e =
        cross(out.vertices[v[1]] - out.vertices[v[0]], out.vertices[v[2]] - out.vertices[v[0]]);
    if (e.x == 0 && e.y == 0 && e.z == 0) continue;
    for (int c = 0; c < 3; ++c) {
      file.indices[3 * kept + c] = v[c];
      if (file_normals) file.normal_indices[3 * kept + c] = file.normal_indices[3 * k + c];
    }
    ++kept;
  }
  out.dropped = n - kept;
  if (kept == 0)
    bad(shown, n == 0 ? "no triangle in the file"
                      : "no triangle left: all " + std::to_string(n) + " have zero area");
  file.indices.resize(3 * kept);
  if (file_normals) file.normal_indices.resize(3 * kept);
  out.indices = std::move(file.indices);
  out.indices.shrink_to_fit();
  out.smooth = smooth;
  if (!smooth) return;
  // Vertex normals: the file's, transformed as normals ((R S)^-T = R S^-1) and normalised; a
  // corner without one, or with a zero one, takes its vertex's area-weighted normal, appended
  // after the file's.
  const std::size_t nv = out.vertices.size(), nf = file.normals.size();
  out.normals.reserve(nf + nv);
  for (const Vec3<double>& nn : file.normals)
    out.normals.push_back(
        unit_or_zero(rot.apply({nn.x / t.scale.x, nn.y / t.scale.y, nn.z / t.scale.z})));
  std::vector<Vec3<double>> area(nv, Vec3<double>{0, 0, 0});
  for (std::size_t k = 0; k < kept; ++k) {
    const std::uint32_t* v = &out.indices[3 * k];
    const Vec3<double> e =
        cross(out.vertices[v[1]] - out.vertices[v[0]], out.vertices[v[2]] - out.vertices[v[0]]);
    for (int c = 0; c < 3; ++c) area[v[c]] = area[v[c]] + e;
  }
  for (const Vec3<double>& a : area) out.normals.push_back(unit_or_zero(a));
  out.normal_indices.resize(3 * kept);
  for (std::size_t c = 0; c < 3 * kept; ++c) {
    const std::uint32_t f = file_normals ? file.normal_indices[c] : MeshFile::kNoNormal;
    const bool usable = f != MeshFile::kNoNormal &&
                        (out.normals[f].x != 0 || out.normals[f].y != 0 || out.normals[f].z != 0);
    out.normal_indices[c] = usable ? f : std::uint32_t(nf + out.indices[c]);
  }
}

MeshFile read_mesh_file(const std::string& path, const std::string& shown) {
  const std::string text = read_input_file(path, "mesh file");
  std::string ext = path.size() >= 4 ? path.substr(path.size() - 4) : "";
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (ext == ".obj") return parse_obj(text, shown);
  if (ext == ".ply") return parse_ply(text, shown);
  bad(shown, "mesh files must end in .obj or .ply");
}

}  // namespace lancer
