// roofgs.convert() and save(): rgs-convert's conversion, with its options by name, from a file or from arrays.
#include <pybind11/eval.h>
#include <pybind11/pybind11.h>

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "internal_py_arguments.h"
#include "internal_py_arrays.h"
#include "internal_py_bindings.h"
#include "internal_py_errors.h"

namespace rgs::python {

namespace {

/// The `edits` argument of convert() or save() (`fn`): a sequence of (name, value) pairs of str in rgs-convert's
/// spelling, parsed by converter::parse_edit_action (("filter-nan",) or ("filter-nan", "") for the flag).
/// TypeError for other types; ValueError "fn(): edits[i]: <the parser's message>".
std::vector<converter::EditAction> edits_arg(py::handle value, const char* fn) {
  const char* pairs = "a sequence of (name, value) pairs of str";
  if (py::isinstance<py::str>(value) || !py::isinstance<py::sequence>(value)) {
    throw type_error(fn, "edits", pairs, value);
  }
  std::vector<converter::EditAction> edits;
  for (const py::handle item : value) {
    const std::string where = "edits[" + std::to_string(edits.size()) + "]";
    if (py::isinstance<py::str>(item) || !py::isinstance<py::sequence>(item)) {
      throw type_error(fn, where.c_str(), "a (name, value) pair of str", item);
    }
    const auto pair = py::reinterpret_borrow<py::sequence>(item);
    if (pair.size() != 1 && pair.size() != 2) {
      throw value_error(fn, where.c_str(), "a (name, value) pair", py::repr(item).cast<std::string>());
    }
    const std::string name = str_arg(pair[0], fn, where.c_str());
    const std::string text = pair.size() == 2 ? str_arg(pair[1], fn, where.c_str()) : std::string();
    auto edit = converter::parse_edit_action(name, text);
    if (!edit.ok()) throw py::value_error(std::string(fn) + "(): " + where + ": " + edit.status().message());
    edits.push_back(std::move(edit).value());
  }
  return edits;
}

/// ConvertOptions from the keyword arguments of convert() or save() (`fn`) that are not the target's (the
/// defaults are ConvertOptions's own).
api::ConvertOptions convert_options(const char* fn, const py::kwargs& kwargs) {
  if (kwargs.contains("lod_chunk") && !kwargs.contains("lod_levels")) {
    throw py::value_error(std::string(fn) + "(): lod_chunk requires lod_levels, as rgs-convert's --lod-chunk does");
  }
  api::ConvertOptions o;
  o.converter_name = "roofgs python";
  py::object spz_frame = py::str("rub");
  for (const auto& [key_obj, value] : kwargs) {
    const std::string key = py::str(key_obj);
    if (key == "to") {
      if (!value.is_none()) o.to = unwrap(api::parse_output_format(str_arg(value, fn, "to")));
    } else if (key == "scale_encoding") {
      const std::string e = str_arg(value, fn, "scale_encoding");
      if (e != "log" && e != "linear") raise(Status(StatusCode::kInvalidArgument, "scale_encoding must be 'linear' or 'log'"));
      o.scale_encoding = e == "log" ? format::ScaleEncoding::kLog : format::ScaleEncoding::kLinear;
    } else if (key == "profile") {
      const std::string p = str_arg(value, fn, "profile");
      if (p != "archive" && p != "runtime") raise(Status(StatusCode::kInvalidArgument, "profile must be 'runtime' or 'archive'"));
      o.profile = p == "archive" ? format::StorageProfile::kArchive : format::StorageProfile::kRuntime;
    } else if (key == "sh_clip_percentile") {
      o.sh_clip_percentile = float(float_arg(value, fn, "sh_clip_percentile", {0.001, 100.0}));
    } else if (key == "sh_dc_bits") {
      o.sh_dc_bits = int_arg<uint32_t>(value, fn, "sh_dc_bits", 8, 16);
      if (o.sh_dc_bits != 8 && o.sh_dc_bits != 16) throw value_error(fn, "sh_dc_bits", "8 or 16", py::repr(value));
    } else if (key == "zstd") {
      o.zstd_sections = cast_arg<std::vector<std::string>>(value, fn, "zstd", "a sequence of str");
    } else if (key == "zstd_level") {
      o.zstd_level = int_arg<int>(value, fn, "zstd_level", 1, 22);
    } else if (key == "position_error") {
      o.archive.position_error = float_arg(value, fn, "position_error", {1e-9, 0.5});
    } else if (key == "sh_degree") {
      if (!value.is_none()) o.sh_degree = int_arg<uint32_t>(value, fn, "sh_degree", 0, 3);
    } else if (key == "lod") {
      if (!value.is_none()) o.read.lod = int_arg<uint32_t>(value, fn, "lod", 0, 63);
    } else if (key == "lod_levels") {
      if (py::isinstance<py::str>(value)) {
        if (value.cast<std::string>() != "auto") {
          throw value_error(fn, "lod_levels", "'auto' or an integer in 1..16", py::repr(value));
        }
        o.lod_levels = 0;
      } else if (!value.is_none()) {
        if (PyBool_Check(value.ptr()) || !PyIndex_Check(value.ptr())) {
          throw type_error(fn, "lod_levels", "'auto' or an int", value);
        }
        o.lod_levels = int_arg<uint32_t>(value, fn, "lod_levels", 1, 16);
      }
    } else if (key == "lod_chunk") {
      o.lod_chunk_gaussians = int_arg<uint32_t>(value, fn, "lod_chunk", 1, uint32_t{1} << 30);
    } else if (key == "memory_limit") {
      o.memory_limit = int_arg<uint64_t>(value, fn, "memory_limit");
    } else if (key == "max_gaussians") {
      o.read.max_gaussians = int_arg<uint64_t>(value, fn, "max_gaussians", 1);
    } else if (key == "max_decompression_ratio") {
      o.read.max_decompression_ratio = int_arg<uint32_t>(value, fn, "max_decompression_ratio", 1, 32768);
    } else if (key == "spz_frame") {
      if (!value.is_none()) spz_frame = py::reinterpret_borrow<py::object>(value);
    } else if (key == "antialiased") {
      o.read.antialiased = cast_arg<bool>(value, fn, "antialiased", "a bool");
    } else if (key == "sanitize") {
      o.sanitize = cast_arg<bool>(value, fn, "sanitize", "a bool");
    } else if (key == "allow_empty") {
      o.allow_empty = cast_arg<bool>(value, fn, "allow_empty", "a bool");
    } else if (key == "edits") {
      if (!value.is_none()) o.edits = edits_arg(value, fn);
    } else if (key == "input_edits") {  // one list of edits a source, before the merge and `edits`
      for (py::handle one : cast_arg<py::sequence>(value, fn, "input_edits", "a sequence of edit lists")) {
        o.input_edits.push_back(one.is_none() ? std::vector<converter::EditAction>{} : edits_arg(one, fn));
      }
    } else {
      const py::object accepted = py::module_::import("roofgs").attr("_keyword_options")(fn);
      throw py::type_error("unexpected keyword argument '" + key + "'; the options are " +
                           py::str(", ").attr("join")(accepted).cast<std::string>());
    }
  }
  const converter::SceneReadOptions read = read_options(spz_frame);
  o.read.spz_frame = read.spz_frame;
  o.read.spz_frame_by_path = read.spz_frame_by_path;
  return o;
}

/// convert() and save() (`fn`, which their errors name): the options of rgs-convert in `kwargs` (by the
/// snake_case of their long options; None never passed), written by `write` (api::convert, api::convert_cloud);
/// with target_psnr / target_bytes the conversion fits the archive profile to them (ConvertOptions::target).
/// Returns the report's dict: rgs-convert --json's (api::convert_report_json) for `src` converted into `dst`.
py::dict convert_with_options(const char* fn, py::kwargs kwargs, const std::string& src, const std::string& dst,
                              const std::function<Result<api::ConvertReport>(const api::ConvertOptions&)>& write) {
  // The target and its views (api::ConvertTarget); the rest are ConvertOptions.
  api::ConvertTarget target;
  auto take = [&](const char* key) -> std::optional<py::object> {
    if (!kwargs.contains(key)) return std::nullopt;
    py::object value = kwargs[key];
    PyDict_DelItemString(kwargs.ptr(), key);
    if (value.is_none()) return std::nullopt;
    return value;
  };
  constexpr uint32_t kMaxCount = 100000, kMaxEvery = 2147483647;
  const char* path_name = std::string(fn) == "save" ? "camera_path" : "path";  // save()'s `path` is its output
  api::CameraChoice& views = target.views;
  if (auto v = take("target_psnr")) target.psnr_db = float_arg(*v, fn, "target_psnr", {1.0, 200.0});
  if (auto v = take("target_bytes")) target.bytes = int_arg<uint64_t>(*v, fn, "target_bytes", 1);
  if (auto v = take("cameras")) views.cameras_path = path_arg(*v, fn, "cameras").string();
  if (auto v = take("every")) views.every = int_arg<uint32_t>(*v, fn, "every", 1, kMaxEvery);
  if (auto v = take("limit")) views.limit = int_arg<uint32_t>(*v, fn, "limit", 1, kMaxEvery);
  if (auto v = take("orbit")) views.orbit = int_arg<uint32_t>(*v, fn, "orbit", 1, kMaxCount);
  if (auto v = take(path_name)) views.path = int_arg<uint32_t>(*v, fn, path_name, 1, kMaxCount);
  if (auto v = take("fly")) views.fly = int_arg<uint32_t>(*v, fn, "fly", 1, kMaxCount);
  if (auto v = take("width")) views.width = int_arg<uint32_t>(*v, fn, "width", 11, kMaxImageSide);
  if (auto v = take("height")) views.height = int_arg<uint32_t>(*v, fn, "height", 11, kMaxImageSide);
  api::ConvertOptions options = convert_options(fn, kwargs);
  if (target.active()) target.device = api::cuda_available() ? api::Device::kCuda : api::Device::kCpu;
  options.target = std::move(target);
  Result<api::ConvertReport> r = Status(StatusCode::kInvalidArgument, "not converted");
  {
    py::gil_scoped_release release;
    r = write(options);
  }
  const std::string report = api::convert_report_json(unwrap(std::move(r)), src, dst, options);
  return py::module_::import("json").attr("loads")(report);
}

}  // namespace

void bind_conversion(py::module_& m) {
  m.def("_convert",
        [](const py::object& src, const PathArg& dst, py::kwargs kwargs) {
          // One path, or a list or tuple of them merged into one scene.
          std::vector<std::string> from;
          const bool several = py::isinstance<py::list>(src) || py::isinstance<py::tuple>(src);
          for (py::handle s : several ? py::iterable(src) : py::iterable(py::make_tuple(src))) {
            from.push_back(path_arg(s, "convert", "src").string());
          }
          std::string name;
          for (const std::string& f : from) name += (name.empty() ? "" : " + ") + f;
          const std::string to = path_arg(dst, "convert", "dst").string();
          return convert_with_options("convert", std::move(kwargs), name, to, [&](const api::ConvertOptions& o) {
            return api::convert(from, to, o);
          });
        },
        py::arg("src"), py::arg("dst"), "convert()'s implementation: the options given, by name");
  m.def("_save",
        [](const PathArg& path, const py::object& means, const py::object& quats, const py::object& scales,
           const py::object& opacities, const py::object& sh, py::kwargs kwargs) {
          const std::string dst = path_arg(path, "save", "path").string();
          format::GaussianCloud cloud = cloud_from_arrays(means, quats, scales, opacities, sh, false);
          return convert_with_options("save", std::move(kwargs), "arrays", dst, [&](const api::ConvertOptions& o) {
            return api::convert_cloud(std::move(cloud), "arrays", dst, o);
          });
        },
        py::arg("path"), py::arg("means"), py::arg("quats"), py::arg("scales"), py::arg("opacities"), py::arg("sh"),
        "save()'s implementation: the options given, by name");
  // convert() and save() take every option of rgs-convert by the snake_case of its long option (test_roofgs.py
  // compares them with rgs-convert --help), as Python functions whose signature inspect can read.
  py::dict scope = m.attr("__dict__");
  py::exec(R"(
def convert(src, dst, *, to=None, sh_degree=None, scale_encoding=None, sh_clip_percentile=None, sh_dc_bits=None,
            zstd=None, profile=None, position_error=None, target_psnr=None, target_bytes=None, cameras=None,
            every=None, limit=None, orbit=None, path=None, fly=None, width=None, height=None, zstd_level=None,
            sanitize=False, allow_empty=False, lod=None, lod_levels=None, lod_chunk=None, memory_limit=None,
            max_gaussians=None, max_decompression_ratio=None, spz_frame=None, antialiased=False, edits=None,
            input_edits=None, **unexpected):
    _refuse_unexpected("convert", unexpected)
    options = {k: v for k, v in locals().items() if k not in ("src", "dst", "unexpected") and v is not None}
    return _convert(src, dst, **options)

def _keyword_options(name):
    """The keyword options of convert() or save(), from their signatures (the one list of them)."""
    import inspect
    parameters = inspect.signature(globals()[name]).parameters.values()
    return [p.name for p in parameters if p.kind == p.KEYWORD_ONLY]

def _refuse_unexpected(name, unexpected):
    if unexpected:
        raise TypeError(name + "() got an unexpected keyword argument " + repr(next(iter(unexpected))) +
                        "; the options are " + ", ".join(_keyword_options(name)))

def save(path, means, quats, scales, opacities, sh, *, to=None, sh_degree=None, scale_encoding=None,
         sh_clip_percentile=None, sh_dc_bits=None, zstd=None, profile=None, position_error=None, target_psnr=None,
         target_bytes=None, cameras=None, every=None, limit=None, orbit=None, camera_path=None, fly=None,
         width=None, height=None, zstd_level=None, sanitize=False, allow_empty=False, lod=None, lod_levels=None,
         lod_chunk=None, memory_limit=None, max_gaussians=None, max_decompression_ratio=None, spz_frame=None,
         antialiased=False, edits=None,
         **unexpected):
    _refuse_unexpected("save", unexpected)
    options = {k: v for k, v in locals().items()
               if k not in ("path", "means", "quats", "scales", "opacities", "sh", "unexpected") and v is not None}
    return _save(path, means, quats, scales, opacities, sh, **options)
)", scope);
  m.attr("convert").attr("__doc__") = py::str(
        "Convert a scene in any format into dst: .rgs, .ply, .spz, .glb or .sog (or a SOG folder's meta.json), as `to` or "
        "dst's extension says. src: a path (str or os.PathLike), or a list or tuple of paths whose scenes are merged "
        "into one before the edits (their Gaussians in the order given, at the highest SH degree, missing bands zero; "
        "differing anti-aliasing flags raise roofgs.Error kInvalidArgument naming both files) "
        "(what rgs-convert does, same options). Returns rgs-convert --json's report as a dict (api::"
        "convert_report_json): input and output (path, bytes, format, ..., notes), gaussians, sh_degree, hygiene "
        "(dropped_gaussians, ...), and errors (per attribute, SH per degree) for a .rgs output. "
        "target_psnr (dB) or target_bytes: rate control of the archive profile (api::ConvertOptions::target, as "
        "rgs-convert --target-psnr / --target-bytes) on the views of cameras (an INRIA cameras.json, every K-th) "
        "an orbit or a path, at width x height; with none of these, the scene's own cameras.json of the 3DGS output "
        "layout beside it, else views guessed from its content; the dict "
        "then has rate_control: target, psnr_mean_db, "
        "psnr_min_db, search_psnr_db, settings (position_error, rotation_bits, rotation_step, scale_bits, "
        "scale_step, opacity_bits, opacity_step, opacity_floor, sh_step_multipliers), views, width, height, "
        "backend, device, encodings, renders, seconds (of which encode_seconds encoding the candidates and "
        "render_seconds loading and rendering them). memory_limit: most bytes of memory the conversion may use "
        "(int; 0 or None: half the physical memory); an input whose estimated peak when read whole is above it "
        "is built out of core when it is a binary PLY converted with lod_levels (the same bytes), else raises "
        "roofgs.Error kLimitExceeded before it is read (api::ConvertOptions::memory_limit). edits: the scene's edits "
        "in the order they act, each a (name, value) pair in rgs-convert's spelling: [('rotate', '0,0,90'), "
        "('filter', 'opacity gt 0.1'), ('crop-box', '-1,-1,-1,1,1,1'), ('filter-nan', '')]; the names are "
        "translate (x,y,z scene units), rotate (x,y,z Euler degrees, extrinsic x then y then z, or a unit quaternion "
        "w,x,y,z; the SH colour turns too), scale (s > 0), filter-nan, filter ('NAME OP VALUE', NAME as in an INRIA "
        "PLY, activated, or red/green/blue: 0.5 + 0.28209479 f_dc), crop-box, "
        "crop-box-outside (minx,miny,minz,maxx,maxy,maxz), crop-sphere, crop-sphere-outside (cx,cy,cz,r), "
        "decimate (N, an integer >= 1, or a fraction in (0, 1): at most that many Gaussians, merged by the levels "
        "of detail's rule; refused out of core) "
        "(api::ConvertOptions::edits, converter::parse_edit_action); a bad one raises ValueError naming edits[i] "
        "and the rule. rgs-convert's --translate, --rotate, --scale, --filter-nan, --filter, --crop-box, "
        "--crop-sphere, their -outside forms and --decimate are this one keyword, since their order matters. "
        "input_edits: a merge's edits of each source before the merge, a list of such lists (None or [] for none; "
        "rgs-convert's actions written after an input; api::ConvertOptions::input_edits)");
  m.attr("save").attr("__doc__") = py::str(
        "Write Gaussians held in arrays to `path` in any output format (.rgs, .ply, .spz, .glb, .sog or a SOG "
        "folder's meta.json), with convert()'s "
        "keyword options. means [N, 3], quats [N, 4] (w, x, y, z; normalized here), scales [N, 3] linear "
        "(exp of the PLY's log scales), opacities [N] in [0, 1] (sigmoid of the PLY's logits), sh [N, K, 3] "
        "(K = 1, 4, 9, 16; PLY f_dc then f_rest reordered coefficient-major); float32 or convertible. The value "
        "rules of a file apply (sanitize=True drops what they reject). Returns convert()'s dict. The arrays are "
        "already in memory: memory_limit is accepted and not checked. edits: as convert()'s, on the arrays");
}

}  // namespace rgs::python
