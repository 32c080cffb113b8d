// Printing and saving benchmark reports: aligned table, CSV, and a gnuplot PNG plot.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <unistd.h>

#include "bench.h"

namespace penumbra::bench {

namespace {

// Writes `text` to `path` through a temporary file in the same directory, then renames it.
Status write_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp-" + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) {
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      return make_error(ErrorCode::Io, path + ": cannot write; check that the directory exists and is writable");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    return make_error(ErrorCode::Io, path + ": cannot replace the file (" + ec.message() + ")");
  }
  return {};
}

std::string csv_escape(const std::string& cell) {
  if (cell.find_first_of(",\"\n") == std::string::npos) return cell;
  std::string out = "\"";
  for (char c : cell) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

std::string format_table(const Report& report) {
  std::vector<std::size_t> width(report.columns.size(), 0);
  for (std::size_t c = 0; c < report.columns.size(); ++c) width[c] = report.columns[c].size();
  for (const auto& row : report.rows)
    for (std::size_t c = 0; c < row.size() && c < width.size(); ++c) width[c] = std::max(width[c], row[c].size());

  std::ostringstream out;
  auto line = [&](const std::vector<std::string>& cells) {
    for (std::size_t c = 0; c < width.size(); ++c) {
      const std::string cell = c < cells.size() ? cells[c] : std::string();
      out << (c ? "  " : "") << cell << std::string(width[c] - cell.size(), ' ');
    }
    out << '\n';
  };
  line(report.columns);
  std::vector<std::string> rule;
  for (std::size_t w : width) rule.push_back(std::string(w, '-'));
  line(rule);
  for (const auto& row : report.rows) line(row);
  if (!report.notes.empty()) out << '\n';
  for (const auto& note : report.notes) out << note << '\n';
  return out.str();
}

Status write_csv(const std::string& path, const Report& report) {
  std::ostringstream out;
  auto line = [&](const std::vector<std::string>& cells) {
    for (std::size_t c = 0; c < cells.size(); ++c) out << (c ? "," : "") << csv_escape(cells[c]);
    out << '\n';
  };
  line(report.columns);
  for (const auto& row : report.rows) line(row);
  return write_atomically(path, out.str());
}

Status write_plot(const std::string& png_path, const std::string& csv_path, const Report& report) {
  const Plot& p = report.plot;
  const int ncols = static_cast<int>(report.columns.size());
  if (p.x_column < 0 || p.x_column >= ncols || p.y_column < 0 || p.y_column >= ncols || p.series_column >= ncols)
    return make_error(ErrorCode::Internal, "benchmark plot names a column the report does not have");

  // One inline data block per series, in order of first appearance.
  std::vector<std::string> series_names;
  std::map<std::string, std::string> blocks;
  for (const auto& row : report.rows) {
    const std::string series = p.series_column >= 0 ? row[static_cast<std::size_t>(p.series_column)] : "all";
    if (!blocks.count(series)) series_names.push_back(series);
    blocks[series] += row[static_cast<std::size_t>(p.x_column)] + " " + row[static_cast<std::size_t>(p.y_column)] + "\n";
  }

  const std::string tmp = png_path + ".tmp-" + std::to_string(::getpid());
  std::ostringstream script;
  script << "set terminal pngcairo noenhanced size 1000,640 font 'sans,10'\n"
         << "set output '" << tmp << "'\n"
         << "set title \"" << p.title << " (data: " << std::filesystem::path(csv_path).filename().string() << ")\"\n"
         << "set xlabel \"" << p.x_label << "\"\nset ylabel \"" << p.y_label << "\"\n"
         << "set grid\nset key outside right top\n"
         << (p.log_x ? "set logscale x\n" : "") << (p.log_y ? "set logscale y\n" : "");
  for (std::size_t i = 0; i < series_names.size(); ++i)
    script << "$d" << i << " << EOD\n" << blocks[series_names[i]] << "EOD\n";
  script << "plot ";
  for (std::size_t i = 0; i < series_names.size(); ++i)
    script << (i ? ", " : "") << "$d" << i << " using 1:2 with " << (p.points_only ? "points" : "linespoints") << " title \"" << series_names[i] << "\"";
  script << "\n";

  FILE* gp = ::popen("gnuplot 2>&1", "w");
  if (gp == nullptr) return make_error(ErrorCode::Io, png_path + ": cannot start gnuplot; run scripts/bootstrap");
  const std::string text = script.str();
  std::fwrite(text.data(), 1, text.size(), gp);
  const int rc = ::pclose(gp);
  std::error_code ec;
  if (rc != 0 || !std::filesystem::exists(tmp)) {
    std::filesystem::remove(tmp, ec);
    return make_error(ErrorCode::Io, png_path + ": gnuplot failed (exit " + std::to_string(rc) +
                                         "); is gnuplot-nox installed? run scripts/bootstrap");
  }
  std::filesystem::rename(tmp, png_path, ec);
  if (ec) return make_error(ErrorCode::Io, png_path + ": cannot replace the file (" + ec.message() + ")");
  return {};
}

}  // namespace penumbra::bench
