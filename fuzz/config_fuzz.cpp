// libFuzzer harness: train --config JSON files (train::config_from_json with the default config,
// and the milestones derived from the result).
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_util.hpp"
#include "retimegs/train/config.hpp"

namespace fuzz = retimegs::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(fuzz::as_text(data, size));
  fuzz::refuse_with_error([&] {
    const retimegs::train::TrainConfig config =
        retimegs::train::config_from_json(text, {}, "config.json");
    config.model_config();
    for (const int milestone : {0, 1, 500, 20000}) config.scaled(milestone);
  });
  return 0;
}
