// roofgs.audit(): what conversions cost, as rgs-audit measures it, as a dict.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "internal_py_arguments.h"
#include "internal_py_bindings.h"
#include "internal_py_errors.h"
#include "rgs/audit/audit.h"
#include "rgs/audit/audit_report.h"
#include "rgs/audit/audit_scene.h"
#include "rgs/converter/attribute_errors.h"

namespace rgs::python {

namespace {

py::dict error_stats(const converter::ErrorStats& e) {
  py::dict d;
  d["max"] = e.max;
  d["rms"] = e.rms;
  d["samples"] = e.samples;
  return d;
}

py::dict attribute_errors(const converter::AttributeErrors& e) {
  py::dict d;
  d["position"] = error_stats(e.position);
  d["rotation_deg"] = error_stats(e.rotation_deg);
  d["scale_relative"] = error_stats(e.scale_relative);
  d["opacity"] = error_stats(e.opacity);
  py::list sh;
  for (const auto& s : e.sh) sh.append(error_stats(s));
  d["sh_by_degree"] = sh;
  return d;
}

}  // namespace

void bind_audit(py::module_& m) {
  m.def("audit",
        [](const PathArg& source_arg, const py::object& candidates_in, std::optional<std::vector<api::Camera>> cameras,
           const std::optional<IntArg>& orbit_arg, const IntArg& width_arg, const IntArg& height_arg,
           const StrArg& device, const py::object& spz_frame, const FloatArg& threshold_arg) {
          const char* fn = "audit";  // the rules of rgs-audit's options
          const std::optional<uint32_t> orbit = int_arg<uint32_t>(orbit_arg, fn, "orbit", 1, 100000);
          const uint32_t width = int_arg<uint32_t>(width_arg, fn, "width", 11, kMaxImageSide);
          const uint32_t height = int_arg<uint32_t>(height_arg, fn, "height", 11, kMaxImageSide);
          const double threshold = float_arg(threshold_arg, fn, "threshold", {-1000.0, 1000.0});
          const std::filesystem::path source = path_arg(source_arg, fn, "source");
          // One path (str or os.PathLike) or a sequence of them.
          const bool one = py::isinstance<py::str>(candidates_in) || py::isinstance<py::bytes>(candidates_in) ||
                           py::hasattr(candidates_in, "__fspath__");
          const std::vector<std::filesystem::path> candidates =
              one ? std::vector<std::filesystem::path>{path_arg(candidates_in, fn, "candidates")}
                  : cast_arg<std::vector<std::filesystem::path>>(candidates_in, fn, "candidates",
                                                                  "a path (str or os.PathLike) or a sequence of them");
          audit::AuditOptions options;
          options.worst_views = 0;
          const bool cuda = resolve_device(str_arg(device, fn, "device")) == api::Device::kCuda;
          options.backend = cuda ? audit::Backend::kCuda : audit::Backend::kCpu;
          audit::AuditFiles files;  // as rgs-audit: the scene's own cameras.json, else views guessed from its content
          files.source = source.string();
          for (const auto& c : candidates) files.candidates.push_back(c.string());
          files.read = read_options(spz_frame);
          files.cameras = cameras;
          files.views.orbit = orbit.value_or(0);
          files.views.width = files.views.orbit_width = width;
          files.views.height = files.views.orbit_height = height;
          Result<audit::AuditResult> result = Status(StatusCode::kInvalidArgument, "not audited");
          {
            py::gil_scoped_release release;
            result = audit::audit_files(files, options);
          }
          const audit::AuditResult r = unwrap(std::move(result));
          py::dict d;
          d["device"] = r.device;
          d["views"] = r.views.size();
          if (!r.views_note.empty()) d["views_note"] = r.views_note;
          d["source"] = py::dict(py::arg("path") = r.source.path, py::arg("format") = r.source.format,
                                 py::arg("bytes") = r.source.file_bytes, py::arg("gaussians") = r.source.gaussians);
          py::list out;
          bool all_passed = true;
          for (size_t i = 0; i < r.candidates.size(); ++i) {
            const audit::CandidateResult& c = r.candidates[i];
            py::dict cd;
            cd["path"] = c.scene.path;
            cd["format"] = c.scene.format;
            cd["bytes"] = c.scene.file_bytes;
            cd["gaussians"] = c.scene.gaussians;
            cd["sh_degree"] = c.scene.sh_degree;
            cd["bytes_per_gaussian"] =
                r.source.gaussians ? double(c.scene.file_bytes) / double(r.source.gaussians) : 0.0;
            py::list sections;
            for (const audit::SectionSize& sec : c.scene.sections) {
              sections.append(py::dict(py::arg("name") = sec.name, py::arg("codec") = sec.codec,
                                       py::arg("stored_bytes") = sec.stored_bytes, py::arg("raw_bytes") = sec.raw_bytes));
            }
            cd["sections"] = sections;
            cd["psnr_mean_db"] = c.summary.psnr_mean_db;
            cd["psnr_min_db"] = c.summary.psnr_min_db;
            cd["ssim_mean"] = c.summary.ssim_mean;
            cd["ssim_min"] = c.summary.ssim_min;
            cd["max_abs_diff"] = c.summary.max_abs_diff;
            cd["worst_view"] = r.views[c.summary.worst_view].name;
            if (c.attributes) {
              cd["errors"] = attribute_errors(c.attributes->errors);
            } else {
              cd["errors_note"] = c.attributes_note;
            }
            cd["notes"] = c.scene.notes;
            // rgs-audit --json's verdict of the candidate (audit_report.cpp).
            const audit::Verdict v = audit::verdict(r, i, threshold);
            all_passed = all_passed && v.passed;
            cd["verdict"] = py::dict(
                py::arg("passed") = v.passed, py::arg("metric") = audit::verdict_metric_name(v.metric),
                py::arg("psnr_mean_db") = v.psnr_mean_db,
                py::arg("whole_frame_psnr_mean_db") = v.whole_frame_psnr_mean_db,
                py::arg("foreground_psnr_mean_db") = v.foreground_psnr_mean_db,
                py::arg("worst_view") = py::dict(py::arg("name") = v.worst_view, py::arg("psnr_db") = v.worst_psnr_db),
                py::arg("bytes_saved") = v.bytes_saved ? py::object(py::int_(*v.bytes_saved)) : py::object(py::none()),
                py::arg("bytes_saved_fraction") =
                    v.bytes_saved ? py::object(py::float_(v.bytes_saved_fraction)) : py::object(py::none()));
            out.append(cd);
          }
          d["candidates"] = out;
          d["verdict"] = py::dict(py::arg("threshold_db") = threshold,
                                  py::arg("criterion") =
                                      "mean PSNR over the views (each candidate's verdict metric) >= threshold_db",
                                  py::arg("passed") = all_passed);
          return d;
        },
        py::arg("source"), py::arg("candidates"), py::kw_only(), py::arg("cameras") = py::none(),
        py::arg("orbit") = py::none(), py::arg("width") = 960, py::arg("height") = 540, py::arg("device") = "auto",
        py::arg("spz_frame") = "rub", py::arg("threshold") = audit::kDefaultVerdictThresholdDb,
        "What conversions cost, as rgs-audit measures it: every candidate (any format load() reads) rendered "
        "against the source on the same views (`cameras`; else an orbit of `orbit` cameras at width x height; else, "
        "as rgs-audit, the source's own cameras.json of the 3DGS output layout beside it or views guessed from its "
        "content, said in the dict's views_note) "
        "with the faithful preset, on the GPU when `device` resolves to CUDA, else the CPU reference. Returns "
        "a dict: device, views, source (path, format, bytes, gaussians) and one dict per candidate: bytes, "
        "bytes_per_gaussian (per Gaussian of the source), sections (.rgs), PSNR mean/min (dB, clamped RGB), "
        "SSIM mean/min, max_abs_diff, worst_view, per-attribute errors when every candidate Gaussian is paired with "
        "a source Gaussian, in whatever order its file keeps them (as rgs-audit pairs them; else errors_note), and "
        "verdict (rgs-audit --json's: metric, foreground where the source's renders have "
        "background, else whole_frame; passed when the mean PSNR in it is at least `threshold` dB; psnr_mean_db "
        "in it, whole_frame_psnr_mean_db, foreground_psnr_mean_db, worst_view name and psnr_db in it, bytes_saved and bytes_saved_fraction against the source); "
        "the dict's verdict: threshold_db, criterion, passed (every candidate passed). `candidates`: one path or "
        "a list of them");
}

}  // namespace rgs::python
