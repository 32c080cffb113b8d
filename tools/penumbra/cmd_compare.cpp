// penumbra compare IMAGE.exr REFERENCE.exr [--reference-error E.exr] [-o DIFF.png]
#include <cmath>
#include <cstdio>
#include <string>

#include "cli.h"
#include "penumbra/image/image_compare.h"

namespace penumbra::cli {

int cmd_compare(Args args) {
  auto error_path = args.take("--reference-error");
  auto out = args.take("-o");
  if (args.missing_value) return fail(kUsage, args.missing_name + " needs a value");
  if (const auto unknown = reject_unknown_options(args, "compare")) return *unknown;
  if (args.rest().size() != 2)
    return fail(kUsage, "compare takes IMAGE.exr REFERENCE.exr [--reference-error E.exr] [-o DIFF.png]");
  if (out && !out->ends_with(".png")) return fail(kUsage, "-o " + *out + ": the difference map is a .png");
  const std::string& a_path = args.rest()[0];
  const std::string& r_path = args.rest()[1];
  auto image = read_exr(a_path);
  if (!image) return fail(kFailure, image.error().message);
  auto reference = read_exr(r_path);
  if (!reference) return fail(kFailure, reference.error().message);
  std::optional<Image> error;
  if (error_path) {
    auto e = read_exr(*error_path);
    if (!e) return fail(kFailure, e.error().message);
    error = std::move(*e);
  }
  auto c = compare_images(*image, *reference, error ? &*error : nullptr);
  if (!c) return fail(kFailure, a_path + " against " + r_path + ": " + c.error().message);
  std::printf("%s against %s: %llu pixels compared\n", a_path.c_str(), r_path.c_str(),
              static_cast<unsigned long long>(c->pixels));
  std::printf("  relative RMSE        %.4f\n", c->rel_rmse);
  std::printf("  mean signed error    %+.4f (relative; positive: brighter than the reference)\n", c->mean_signed_error);
  std::printf("  SSIM (luminance)     %.4f\n", c->ssim);
  if (error)
    std::printf("  reference's error    %.4f (relative standard error: the part of the RMSE its noise explains)\n",
                c->reference_rel_stderr);
  else
    std::printf("  reference's error    unknown (pass --reference-error E.exr, e.g. from penumbra render --offline "
                "reference --std-error)\n");
  if (out) {
    if (Status s = write_image(difference_image(*image, *reference), *out); !s) return fail(kFailure, s.error().message);
    std::printf("  difference map       %s (red: brighter, blue: darker, full at +-50 %%; grey: not compared)\n",
                out->c_str());
  }
  return kSuccess;
}

}  // namespace penumbra::cli
