// The audit's HTML report: one self-contained page (no network access needed) drawn from the audit's JSON, with
// its figures as inline SVG written by the audit and the worst views' images as base64 PNG.
#pragma once

#include <functional>
#include <string>

#include "rgs/audit/audit.h"
#include "rgs/audit/audit_report.h"
#include "rgs/format/status.h"

namespace rgs::audit {

/// Gives the image a report's JSON names ("source_image", "candidate_image", "diff_image" of a worst view:
/// a path relative to the JSON file).
using ReportImageReader = std::function<Result<Image8>(const std::string& name)>;

/// The HTML report of an audit JSON (audit_json's text, schema kAuditSchemaName version kAuditSchemaVersion),
/// from the top: the verdict; the source, the summary table and, where the source has background, why its
/// whole-frame PSNR is inflated; a size/quality chart when there are several candidates (labels
/// SERIES@POINT drawn as one curve); per-view PSNR (whole frame solid, foreground dashed) and SSIM as a plot and
/// a table; the size per section and per Gaussian as a chart; per candidate its sizes, attribute errors, colour
/// bar and worst views (source and candidate under a slider beside the heatmap of |d|, coloured with inferno on
/// the candidate's own heat scale). Docs: docs/AUDITS.md "Report and JSON reference". Every text from the JSON
/// (labels, paths, view names) is escaped. A worst view that names no images is left out of the page.
/// Deterministic: the same JSON and images give the same bytes.
/// @return UTF-8 HTML; kInvalidArgument when the text is not an rgs-audit JSON of this schema version or lacks a
///         field the page needs (the message says which), the reader's errors (with the image's name).
Result<std::string> report_html(const std::string& json_text, const ReportImageReader& read_image);

/// The HTML report of `result` as audit_json(result, options) writes it, with the worst views' images taken
/// from `result` (written or not).
Result<std::string> report_html(const AuditResult& result, const ReportOptions& options);

/// The HTML report of the JSON file `json_path` of an earlier audit, its images read (read_netpbm) from the
/// files it names next to it (rgs-audit --report-from).
/// @return as report_html, kIoError naming a file that cannot be read, kCorruptData for a damaged image.
Result<std::string> report_html_from_file(const std::string& json_path);

}  // namespace rgs::audit
