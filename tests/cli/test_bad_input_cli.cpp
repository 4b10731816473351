// The bad-input suite: hostile arguments and files given to every command (issue 26's findings and
// more). Each must exit 2 with exactly one line naming the culprit, within a time limit (no hang),
// and leave the folder tree exactly as it found it: no output, no temporary, no damaged input.
#include <sys/stat.h>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_run.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

// ROOT/scene (synthetic, 2 cameras x 3 frames of 32x24), ROOT/run (a 4-step training run) and
// ROOT/model.rgs (its model), made once for the suite.
class BadInputCli : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new test::TempDir();
    const fs::path d = root_->path();
    auto r = test::run_cli_timed(
        "synth --preset minimal --cameras 2 --frames 3 --size 32x24 "
        "--threads 2 --out " +
        (d / "scene").string());
    ASSERT_EQ(r.status, 0) << r.err;
    r = test::run_cli_timed("train --scene " + (d / "scene").string() + " --out " +
                            (d / "run").string() + " --iters 4 --cap 300 --threads 2");
    ASSERT_EQ(r.status, 0) << r.err;
    fs::copy_file(d / "run" / "model.rgs", d / "model.rgs");
    // The device outputs: a link to /dev/null, so that a regression that replaces the output
    // (a build whose refusal is broken once replaced /dev/null itself by a folder) only replaces
    // the link.
    fs::create_symlink("/dev/null", d / "null");
  }
  static void TearDownTestSuite() {
    delete root_;
    root_ = nullptr;
  }
  static test::TempDir* root_;
};
test::TempDir* BadInputCli::root_ = nullptr;

struct Case {
  std::string args;                    // {D} stands for the suite's folder
  std::vector<std::string> fragments;  // each must appear in the error line ({D} replaced too)
  std::function<void(const fs::path&)> setup = {};  // run once before the command
};

std::string expand(std::string text, const fs::path& d) {
  for (std::size_t at; (at = text.find("{D}")) != std::string::npos;)
    text.replace(at, 3, d.string());
  return text;
}

void write(const fs::path& path, const std::string& text) {
  test::write_text(path, text);
}

void fifo(const fs::path& path) {
  fs::create_directories(path.parent_path());
  ASSERT_EQ(::mkfifo(path.c_str(), 0644), 0) << path;
}

// A copy of the scene whose scene.json is replaced by `node` (a FIFO).
void scene_with_fifo_json(const fs::path& d) {
  fs::copy(d / "scene", d / "fifo_scene", fs::copy_options::recursive);
  fs::remove(d / "fifo_scene" / "scene.json");
  fifo(d / "fifo_scene" / "scene.json");
}

void run_cases(const fs::path& d, const std::vector<Case>& cases) {
  for (const Case& c : cases) {
    if (c.setup) c.setup(d);
    const std::string args = expand(c.args, d);
    const auto before = test::snapshot(d);
    const auto r = test::run_cli_timed(args, 60);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.err;
    EXPECT_TRUE(test::is_single_error_line(r.err)) << args << "\n" << r.err;
    for (const std::string& f : c.fragments)
      EXPECT_NE(r.err.find(expand(f, d)), std::string::npos) << args << "\n" << r.err << "\n" << f;
    EXPECT_EQ(test::snapshot_diff(before, test::snapshot(d)), "") << args;
  }
}

// A Panoptic train_meta.json of one camera and one frame whose 'fn' is `file`.
std::string panoptic_meta(const std::string& file) {
  return R"({"w":32,"h":24,"k":[[[[30,0,16],[0,30,12],[0,0,1]]]],)"
         R"("w2c":[[[[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]]],"fn":[[")" +
         file + R"("]],"cam_id":[[0]]})";
}

// Two window models of the scene, D/w0 (frames 0..1) and D/w1 (1..2), every frame a training
// frame.
void train_windows(const fs::path& d) {
  for (const char* window : {"0:1", "1:2"}) {
    const std::string out = (d / (std::string("w") + window[0])).string();
    const auto r = test::run_cli_timed("train --scene " + (d / "scene").string() +
                                       " --train-frames all --iters 2 --cap 300 --threads 2 "
                                       "--window " +
                                       window + " --out " + out);
    ASSERT_EQ(r.status, 0) << r.err;
  }
}

const std::string kScene = " --scene {D}/scene";
const std::string kModel = " --model {D}/model.rgs";

// Issue 26's findings that a command line reproduces.
TEST_F(BadInputCli, IssueFindingsExitTwoInOneLineAndLeaveNothing) {
  const std::string train = "train" + kScene + " --out {D}/new_run --iters 3";
  const std::vector<Case> cases = {
      // Crashes.
      {train + " --config {D}/c1.json",
       {"'checkpoint_every'"},
       [](const fs::path& d) { write(d / "c1.json", R"({"checkpoint_every":0})"); }},
      {train + " --config {D}/c2.json",
       {"'relocate_every'"},
       [](const fs::path& d) {
         write(d / "c2.json", R"({"scale_schedule":false,"relocate_every":0})");
       }},
      {train + " --config {D}/c3.json",
       {"'sh_degree_every'"},
       [](const fs::path& d) {
         write(d / "c3.json", R"({"scale_schedule":false,"sh_degree_every":0})");
       }},
      {train + " --config {D}/c4.json",
       {"'stretch_every'"},
       [](const fs::path& d) {
         write(d / "c4.json", R"({"scale_schedule":false,"stretch_every":0})");
       }},
      {train + " --config {D}/c5.json",
       {"'max_sh_degree'"},
       [](const fs::path& d) {
         write(d / "c5.json", R"({"scale_schedule":false,"sh_degree_every":1,"max_sh_degree":10})");
       }},
      {"render" + kModel + kScene + " --camera cam00 --time 1 --threads 100000 --out {D}/t.png",
       {"--threads"}},
      // Hang.
      {"sheet --scene {D}/fifo_scene --out {D}/sheet.png",
       {"{D}/fifo_scene/scene.json", "not a regular file"},
       scene_with_fifo_json},
      {"import panoptic --in {D}/pan --out {D}/imported",
       {"{D}/pan/train_meta.json", "camera"},
       [](const fs::path& d) {
         write(d / "pan" / "train_meta.json",
               R"({"w":4,"h":4,"k":[[]],"w2c":[[]],"fn":[[]],"cam_id":[[]]})");
       }},
      // Path traversal.
      {"import nerfstudio --in {D}/ns --out {D}/imported",
       {"../../escape"},
       [](const fs::path& d) {
         fs::create_directories(d / "ns");
         fs::copy_file(d / "scene" / "images" / "cam00" / "00000.png", d / "ns" / "a.png");
         write(d / "ns" / "transforms.json",
               R"({"fl_x":30,"fl_y":30,"cx":16,"cy":12,"w":32,"h":24,"frames":[)"
               R"({"file_path":"a.png","time":0,"camera":"../../escape","transform_matrix":)"
               R"([[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]}]})");
       }},
      {"sheet --scene {D}/dotdot_scene --out {D}/sheet.png",
       {"'..'"},
       [](const fs::path& d) {
         fs::create_directories(d / "dotdot_scene");
         std::string json = test::read_text(d / "scene" / "scene.json");
         json.replace(json.find("\"cam00\""), 7, "\"..\"");
         write(d / "dotdot_scene" / "scene.json", json);
       }},
      // Outputs that destroy inputs (with --force: without it every one is "already exists").
      {"eval" + kModel + kScene + " --frames 1 --force --out {D}/scene/scene.json",
       {"{D}/scene/scene.json", "scene file"}},
      {"sheet" + kScene + " --force --out {D}/scene/images/cam00/00000.png",
       {"{D}/scene/images/cam00/00000.png", "scene's images folder"}},
      {"eval" + kModel + kScene + " --frames 1 --force --out {D}/null", {"{D}/null", "device"}},
      {"import colmap --in {D}/scene --out {D}/scene --force", {"{D}/scene", "source"}},
      {"render" + kModel + kScene + " --camera cam00 --times 0:2:1 --force --out {D}/model.rgs",
       {"{D}/model.rgs", "is the model"}},
      {"export" + kModel + " --times 0:2:1 --force --out {D}/model.rgs",
       {"{D}/model.rgs", "is the model"}},
      // Unchecked values.
      {train + " --config {D}/c6.json",
       {"'cap'"},
       [](const fs::path& d) { write(d / "c6.json", R"({"cap":-1})"); }},
      {train + " --config {D}/c7.json",
       {"'growth'"},
       [](const fs::path& d) { write(d / "c7.json", R"({"growth":-1})"); }},
      {train + " --config {D}/c8.json",
       {"'min_opacity'"},
       [](const fs::path& d) { write(d / "c8.json", R"({"min_opacity":2})"); }},
      {train + " --config {D}/c9.json",
       {"'lr_means'"},
       [](const fs::path& d) { write(d / "c9.json", R"({"lr_means":-1e-4})"); }},
      {train + " --config {D}/c10.json",
       {"'max_sh_degree'"},
       [](const fs::path& d) { write(d / "c10.json", R"({"max_sh_degree":-1})"); }},
      {train + " --config {D}/c11.json",
       {"'iters'", "2.5"},
       [](const fs::path& d) { write(d / "c11.json", R"({"iters":2.5})"); }},
      {train + " --config {D}/c12.json",
       {"'checkpoint_every'"},
       [](const fs::path& d) { write(d / "c12.json", R"({"checkpoint_every":-1})"); }},
      {train + " --config {D}/c13.json",
       {"'flow_weight_start'"},
       [](const fs::path& d) { write(d / "c13.json", R"({"flow_weight_start":0})"); }},
      {train + " --config {D}/c14.json",
       {"'iters'", "1e+20"},
       [](const fs::path& d) { write(d / "c14.json", R"({"iters":1e20})"); }},
      // Memory from a number.
      {"render" + kModel + kScene + " --camera cam00 --slowmo 1000000000 --out {D}/slow/",
       {"--slowmo"}},
      {"render" + kModel + kScene +
           " --path cam00,cam01 --time 1 --path-frames 1000000000 --out "
           "{D}/path/",
       {"--path-frames"}},
      {"synth --preset minimal --size 100000x100000 --out {D}/big", {"--size"}},
      // Messages: libpng's own lines, a config type error that does not name the key.
      {"sheet --scene {D}/png_scene --cameras cam00 --out {D}/sheet.png",
       {"{D}/png_scene/images/cam00/00000.png", "truncated PNG"},
       [](const fs::path& d) {
         fs::copy(d / "scene", d / "png_scene", fs::copy_options::recursive);
         const fs::path png = d / "png_scene" / "images";
         write(png / "cam00" / "00000.png",
               test::read_text(png / "cam00" / "00000.png").substr(0, 300));
         std::string bytes = test::read_text(png / "cam01" / "00000.png");
         bytes[60] = char(bytes[60] ^ 0xFF);  // inside the first IDAT chunk
         write(png / "cam01" / "00000.png", bytes);
       }},
      {"train --scene {D}/png_scene --out {D}/new_run --iters 3",
       {"{D}/png_scene/images/cam0", "PNG"}},
      {"sheet --scene {D}/png_scene --cameras cam01 --out {D}/sheet.png",
       {"{D}/png_scene/images/cam01/00000.png", "CRC mismatch"}},
      {train + " --config {D}/c15.json",
       {"'seed'"},
       [](const fs::path& d) { write(d / "c15.json", R"({"seed":"x"})"); }},
      // Run folders: a bad input leaves no run folder.
      {"train --scene {D}/nowhere --out {D}/new_run", {"{D}/nowhere"}},
      {train + " --ablate bogus", {"bogus"}},
  };
  run_cases(root_->path(), cases);
}

// A copy D/NAME of the scene whose scene.json has `value` at JSON pointer `pointer`.
void scene_with(const fs::path& d, const std::string& name, const std::string& pointer,
                const nlohmann::json& value) {
  fs::copy(d / "scene", d / name, fs::copy_options::recursive);
  nlohmann::json scene = nlohmann::json::parse(test::read_text(d / name / "scene.json"));
  scene[nlohmann::json::json_pointer(pointer)] = value;
  write(d / name / "scene.json", scene.dump());
}

// Issue 44's findings of limits and messages: absurd but finite values, one limit per quantity
// (core/limits.hpp) checked where a reader first sees it, and the key or option named.
TEST_F(BadInputCli, Issue44LimitsAndMessagesExitTwoInOneLineAndLeaveNothing) {
  const std::string train = "train" + kScene + " --out {D}/new_run --iters 3";
  const std::string render = "render" + kModel + kScene + " --camera cam00";
  const std::vector<Case> cases = {
      // Absurd rates and weights: refused at config load, no run folder left.
      {train + " --config {D}/l1.json",
       {"{D}/l1.json", "'lr_means' = 1e+308", "[0, 1]"},
       [](const fs::path& d) { write(d / "l1.json", R"({"lr_means":1e308})"); }},
      {train + " --config {D}/l2.json",
       {"'opacity_reg' = 1e+300"},
       [](const fs::path& d) { write(d / "l2.json", R"({"opacity_reg":1e300})"); }},
      // Image sizes: a 400-byte camera path of 65536x65536 frames, a 100000x100000 camera.
      {"render" + kModel + kScene + " --camera-path {D}/big_path.json --out {D}/bp/",
       {"{D}/big_path.json", "render_width = 65536", "16384"},
       [](const fs::path& d) {
         write(d / "big_path.json",
               R"({"camera_type":"perspective","render_width":65536,"render_height":65536,)"
               R"("fps":24,"camera_path":[{"camera_to_world":[1,0,0,0,0,1,0,0,0,0,1,5,0,0,0,1],)"
               R"("fov":60}]})");
       }},
      {"sheet --scene {D}/big_scene --out {D}/sheet.png",
       {"'cameras[0].width' = 100000", "16384"},
       [](const fs::path& d) { scene_with(d, "big_scene", "/cameras/0/width", 100000); }},
      {"sheet" + kScene + " --tile-width 1000000 --out {D}/sheet.png",
       {"--tile-width", "1000000", "16384"}},
      // Focal lengths, translations and frame rates.
      {"train --scene {D}/fx_scene --out {D}/new_run --iters 3",
       {"'cameras[1].fx' = 1e+308"},
       [](const fs::path& d) { scene_with(d, "fx_scene", "/cameras/1/fx", 1e308); }},
      {"train --scene {D}/far_scene --out {D}/new_run --iters 3",
       {"'cameras[0].world_to_camera[0][3]' = 1e+308"},
       [](const fs::path& d) {
         scene_with(d, "far_scene", "/cameras/0/world_to_camera/0/3", 1e308);
       }},
      {render + " --times 0:2:1 --fps 1e-300 --out {D}/t.mp4", {"--fps = 1e-300"}},
      // Scales giving an image too small to show anything.
      {render + " --time 1 --scale 1e-9 --out {D}/t.png", {"--scale", "0x0", "[8, 16384]"}},
      // Values CLI11 would wrap, outputs of the wrong kind, an empty address.
      {train + " --seed -1", {"--seed", "-1"}},
      {"synth --preset minimal --seed -1 --out {D}/s", {"--seed", "-1"}},
      {"merge --out {D}/x.png {D}/model.rgs", {"--out {D}/x.png", ".rgs"}},
      {"view" + kModel + " --host ''", {"--host", "address"}},
      // A NUL in a quoted name is escaped, not where the message ends.
      {train + " --config {D}/l3.json",
       {"unknown config key 'lr_\\x00means'"},
       [](const fs::path& d) { write(d / "l3.json", R"({"lr_\u0000means":1})"); }},
      {"sheet --scene {D}/nul_scene --out {D}/sheet.png",
       {"camera name 'cam\\x0000'", "cannot be a folder name"},
       [](const fs::path& d) {
         scene_with(d, "nul_scene", "/cameras/0/name",
                    std::string("cam\0"
                                "00",
                                6));
       }},
  };
  run_cases(root_->path(), cases);
}

// Hostile cases beyond the findings, on every command.
TEST_F(BadInputCli, MoreHostileCasesExitTwoInOneLineAndLeaveNothing) {
  const std::string render = "render" + kModel + kScene + " --camera cam00";
  const std::vector<Case> cases = {
      // Inputs that are not regular files.
      {render + " --retime {D}/retime.fifo --out {D}/r/",
       {"{D}/retime.fifo", "FIFO"},
       [](const fs::path& d) { fifo(d / "retime.fifo"); }},
      {"render" + kModel + kScene + " --camera-path {D}/path.fifo --out {D}/r/",
       {"{D}/path.fifo", "FIFO"},
       [](const fs::path& d) { fifo(d / "path.fifo"); }},
      {"export --model {D}/model.fifo --time 1 --out {D}/e.ply",
       {"{D}/model.fifo", "FIFO"},
       [](const fs::path& d) { fifo(d / "model.fifo"); }},
      {"eval --model /dev/zero" + kScene + " --out {D}/m.json", {"/dev/zero", "device"}},
      {"train" + kScene + " --config /dev/zero --out {D}/new_run", {"/dev/zero", "device"}},
      {"train" + kScene + " --config {D}/config.fifo --out {D}/new_run",
       {"{D}/config.fifo", "FIFO"},
       [](const fs::path& d) { fifo(d / "config.fifo"); }},
      {"render --model {D}/scene" + kScene + " --camera cam00 --time 1 --out {D}/t.png",
       {"{D}/scene", "folder"}},
      {"import videos --in {D}/scene/images --calib {D}/calib.fifo --out {D}/imported",
       {"{D}/calib.fifo", "FIFO"},
       [](const fs::path& d) { fifo(d / "calib.fifo"); }},
      {"train --scene {D}/flow_scene --out {D}/new_run --iters 3",
       {"{D}/flow_scene/flow/cam00/00000_00002.flo", "FIFO"},
       [](const fs::path& d) {
         fs::copy(d / "scene", d / "flow_scene", fs::copy_options::recursive);
         fs::remove(d / "flow_scene" / "flow" / "cam00" / "00000_00002.flo");
         fifo(d / "flow_scene" / "flow" / "cam00" / "00000_00002.flo");
       }},
      // Outputs onto inputs, devices and FIFOs.
      {render + " --time 1 --out {D}/null", {"{D}/null", "device"}},
      {render + " --time 1 --force --out {D}/out.fifo",
       {"{D}/out.fifo", "FIFO"},
       [](const fs::path& d) { fifo(d / "out.fifo"); }},
      {"synth --preset minimal --force --out {D}/null", {"{D}/null", "device"}},
      {"eval" + kModel + kScene +
           " --frames 1 --force --save-renders {D}/scene/images --out "
           "{D}/m.json",
       {"--save-renders", "{D}/scene/images"}},
      {render + " --times 0:2:1 --force --out {D}/scene", {"{D}/scene", "holds"}},
      {"export --model {D}/model.rgs --time 1 --force --out {D}/link.ply",
       {"is the model"},
       [](const fs::path& d) { fs::create_symlink(d / "model.rgs", d / "link.ply"); }},
      {"import nerfstudio --in {D}/scene/images --out {D}/scene --force", {"holds the source"}},
      {"train" + kScene + " --out {D}/scene/images --force", {"{D}/scene/images"}},
      {"train" + kScene + " --out {D}/model.rgs", {"{D}/model.rgs", "is a file"}},
      {"train" + kScene + " --config {D}/run/config.json --out {D}/run --force",
       {"{D}/run/config.json", "config file"}},
      // Numbers out of range.
      {render + " --time 1 --threads -1 --out {D}/t.png", {"--threads"}},
      {render + " --time 1 --fps 0 --out {D}/t.mp4", {"--fps"}},
      {render + " --time nan --out {D}/t.png", {"time nan"}},
      {render + " --time 1 --size 0x0 --out {D}/t.png", {"--size"}},
      {render + " --time 1 --scale 1e9 --out {D}/t.png", {"--scale"}},
      {render + " --time 1 --near -1 --out {D}/t.png", {"--near"}},
      {"render" + kModel + kScene + " --path cam00,cam01 --time 1 --path-frames 0 --out {D}/p/",
       {"--path-frames"}},
      {"export" + kModel + " --times 0:1:0 --out {D}/ex/", {"--times"}},
      {"eval" + kModel + kScene + " --frames 99999 --out {D}/m.json", {"99999"}},
      {"eval" + kModel + kScene + " --cameras nosuch --out {D}/m.json", {"nosuch"}},
      {"synth --preset minimal --frames 1000000000 --out {D}/s", {"--frames"}},
      {"synth --preset minimal --cameras 0 --out {D}/s", {"--cameras"}},
      {"train" + kScene + " --out {D}/new_run --iters 0", {"iters"}},
      {"train" + kScene + " --out {D}/new_run --iters 1e20", {"--iters"}},
      {"train" + kScene + " --out {D}/new_run --threads 5000", {"--threads"}},
      {"prepare" + kScene + " --points ply", {"--points"}},
      {"import colmap --in {D}/nowhere --out {D}/imported", {"{D}/nowhere"}},
      // Panoptic 'fn' entries that leave the source's ims/ folder.
      {"import panoptic --in {D}/pan_abs --out {D}/imported",
       {"{D}/pan_abs/train_meta.json", "'fn[0][0]'", "'/etc/hostname'", "absolute path"},
       [](const fs::path& d) {
         write(d / "pan_abs" / "train_meta.json", panoptic_meta("/etc/hostname"));
       }},
      {"import panoptic --in {D}/pan_up --out {D}/imported",
       {"{D}/pan_up/train_meta.json", "'fn[0][0]'", "'../../scene/images/cam00/00000.png'", "'..'"},
       [](const fs::path& d) {
         write(d / "pan_up" / "train_meta.json",
               panoptic_meta("../../scene/images/cam00/00000.png"));
       }},
      // A second run into a finished one, and a resume with fewer steps than it has.
      {"train" + kScene + " --out {D}/run", {"{D}/run", "--resume"}},
      {"train" + kScene + " --out {D}/run --resume --iters 2", {"{D}/run", "step 4"}},
  };
  run_cases(root_->path(), cases);
}

// User strings that hold control characters (a newline, an ESC) are quoted in the message as
// visible escapes: the message stays one line and cannot drive the terminal.
TEST_F(BadInputCli, ControlCharactersInQuotedNamesAreEscaped) {
  const std::vector<Case> cases = {
      // A scene path with a newline (single quotes: the shell passes it as it is).
      {"train --scene '{D}/no\nscene' --out {D}/new_run", {"{D}/no\\nscene"}},
      {"sheet --scene '{D}/tab\tscene' --out {D}/sheet.png", {"{D}/tab\\tscene"}},
      // A camera name with a newline and an ESC (JSON escapes in scene.json).
      {"sheet --scene {D}/ctrl_scene --out {D}/sheet.png",
       {"cam\\n\\x1b[31m00", "cannot be a folder name"},
       [](const fs::path& d) {
         fs::create_directories(d / "ctrl_scene");
         std::string json = test::read_text(d / "scene" / "scene.json");
         json.replace(json.find("\"cam00\""), 7, R"("cam\n\u001b[31m00")");
         write(d / "ctrl_scene" / "scene.json", json);
       }},
      // A camera asked for by a name with a newline and a DEL.
      {"render" + kModel + kScene + " --camera 'cam\n0\x7f' --time 1 --out {D}/t.png",
       {"cam\\n0\\x7f"}},
  };
  run_cases(root_->path(), cases);
}

// A NUL in any value a message quotes is escaped (retimegs::Error), not where the message ends.
TEST_F(BadInputCli, NulsInQuotedValuesAreEscaped) {
  const std::string nul("\0", 1);
  const std::vector<Case> cases = {
      {"sheet --scene {D}/nul_split --out {D}/sheet.png",
       {"'cameras[0].split' must be \"train\" or \"test\", got \"tr\\x00ain\""},
       [&](const fs::path& d) {
         scene_with(d, "nul_split", "/cameras/0/split", "tr" + nul + "ain");
       }},
      {"sheet --scene {D}/nul_format --out {D}/sheet.png",
       {"got \"retimegs\\x00-scene\""},
       [&](const fs::path& d) {
         scene_with(d, "nul_format", "/format", "retimegs" + nul + "-scene");
       }},
  };
  run_cases(root_->path(), cases);
}

// A command that fails after printing progress (prepare's flow, its second image truncated):
// when stderr is not a terminal, the progress lines go to stdout with the log, and stderr holds
// the one error line alone, for a script to read.
TEST_F(BadInputCli, AFailingCommandsStderrIsItsErrorLineAlone) {
  const fs::path d = root_->path();
  fs::copy(d / "scene", d / "cut_scene", fs::copy_options::recursive);
  fs::remove_all(d / "cut_scene" / "flow");
  const fs::path cut = d / "cut_scene" / "images" / "cam01" / "00002.png";
  const std::string png = test::read_text(cut);
  write(cut, png.substr(0, png.size() / 2));
  const auto r = test::run_cli("prepare --scene " + (d / "cut_scene").string() + " --threads 1");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_TRUE(test::is_single_error_line(r.err)) << r.err;
  EXPECT_NE(r.err.find(cut.string() + ": truncated PNG"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("flow 1/2 (50%)"), std::string::npos) << r.out;  // cam00's, before it
}

// Paths the system cannot look up: a name longer than the file system allows is reported with
// the path and the system's reason, never as an "unexpected error".
TEST_F(BadInputCli, PathsTheSystemRefusesAreNamedWithTheReason) {
  const std::string long_name = "{D}/" + std::string(300, 'n');
  const std::vector<Case> cases = {
      {"train --scene " + long_name + " --out {D}/new_run", {"File name too long"}},
      {"import colmap --in " + long_name + " --out {D}/imported", {"File name too long"}},
      {"sheet --scene " + long_name + " --out {D}/sheet.png", {"File name too long"}},
  };
  run_cases(root_->path(), cases);
}

// Commands that came after the first hostile pass: time windows (train / prepare --window),
// merge, slurm, view and export --web.
TEST_F(BadInputCli, WindowMergeSlurmViewAndWebCasesExitTwoInOneLineAndLeaveNothing) {
  const std::string train = "train" + kScene + " --out {D}/new_run --iters 3";
  const std::string prepare = "prepare" + kScene;
  const std::string slurm = "slurm" + kScene + " --out {D}/slurm_run";
  const std::string merge = "merge --out {D}/merged.rgs ";
  const std::string w0 = "{D}/w0/model.rgs", w1 = "{D}/w1/model.rgs";
  const std::string web = "export" + kModel + kScene;
  const std::vector<Case> cases = {
      // train / prepare --window: reversed, not numbers, past the clip, negative, empty, and a
      // window whose ends are not training frames (even frames by default).
      {train + " --window 5:3", {"--window", "'5:3'"}},
      {train + " --window a:b", {"--window", "'a:b'"}},
      {train + " --window 0:100000", {"window 0:100000", "not a training frame"}},
      {train + " --window=-1:4", {"--window", "'-1:4'"}},
      {train + " --window 0:0", {"--window", "'0:0'"}},
      {train + " --window 1:2", {"window 1:2", "frame 1 is not a training frame"}},
      {prepare + " --window 5:3", {"--window", "'5:3'"}},
      {prepare + " --window a:b", {"--window", "'a:b'"}},
      {prepare + " --window 0:100000", {"window 0:100000", "not a training frame"}},
      {prepare + " --window=-1:4", {"--window", "'-1:4'"}},
      {prepare + " --window 1:2", {"window 1:2", "frame 1 is not a training frame"}},
      // merge: the same window twice, a whole-clip model with a window, a missing model, a
      // folder, the output onto an input or onto the folder holding one.
      {merge + w0 + " " + w0, {w0, "overlap"}, train_windows},
      {merge + "{D}/model.rgs " + w1, {"{D}/model.rgs", w1, "time grids"}},
      {merge + w0 + " {D}/nowhere.rgs", {"{D}/nowhere.rgs"}},
      {merge + w0 + " {D}/scene", {"{D}/scene", "folder"}},
      {"merge --force --out " + w0 + " " + w0 + " " + w1, {"--out " + w0, "is the model"}},
      {"merge --force --out {D}/w0 " + w0 + " " + w1, {"--out {D}/w0", "holds the model"}},
      // slurm: window counts out of range, sbatch options that are not one option, run folders
      // on the scene, a file or a device, training settings that train would refuse.
      {slurm + " --windows 0", {"--windows 0"}},
      {slurm + " --windows 1000000", {"--windows 1000000"}},
      {slurm + " --windows 1 '--sbatch-arg=--time=1\n#SBATCH --x'",
       {"--sbatch-arg", "--time=1\\n#SBATCH --x"}},
      {slurm + " --windows 1 --sbatch-arg=partition=gpu", {"--sbatch-arg", "'partition=gpu'"}},
      {"slurm" + kScene + " --out {D}/scene --windows 1", {"--out {D}/scene", "scene file"}},
      {"slurm" + kScene + " --out {D}/scene/images --windows 1 --force",
       {"--out {D}/scene/images", "scene's images folder"}},
      {"slurm" + kScene + " --out {D}/model.rgs --windows 1", {"{D}/model.rgs", "not a folder"}},
      {"slurm" + kScene + " --out {D}/null --windows 1", {"{D}/null", "not a folder"}},
      {slurm + " --windows 1 --iters 0", {"'iters'"}},
      {slurm + " --windows 1 --config {D}/nowhere.json", {"{D}/nowhere.json"}},
      {slurm + " --windows 1 --preset bogus", {"--preset", "bogus"}},
      // view: ports out of range, a missing model, a folder or a device as the model.
      {"view" + kModel + " --port 70000", {"--port", "70000"}},
      {"view" + kModel + " --port=-1", {"--port", "-1"}},
      {"view --model {D}/nowhere.rgs", {"{D}/nowhere.rgs"}},
      {"view --model {D}/scene", {"{D}/scene", "folder"}},
      {"view --model /dev/zero", {"/dev/zero", "device"}},
      // export --web onto the model, an existing file, the scene's files, a device.
      {web + " --web {D}/model.rgs --force", {"--web {D}/model.rgs", "is the model"}},
      {web + " --web {D}/run/config.json", {"{D}/run/config.json", "exists"}},
      {web + " --web {D}/scene/images --force", {"--web {D}/scene/images", "images folder"}},
      {web + " --web {D}/scene/scene.json --force", {"--web {D}/scene/scene.json", "scene file"}},
      {web + " --web {D}/null --force", {"{D}/null", "device"}},
  };
  run_cases(root_->path(), cases);
}

// Mistakes on the own-capture path (issue 43), named in the user's words.
TEST_F(BadInputCli, OwnCaptureMistakesAreNamedInTheUsersWords) {
  const std::vector<Case> cases = {
      {"sheet" + kScene + " --out {D}/sheet.jpg", {"--out {D}/sheet.jpg", "ending in .png"}},
      {"train" + kScene + " --out {D}/new_run --iters 3 --downscale 0.5", {"--downscale", "0.5"}},
      {"render" + kModel + kScene + " --camera cam00 --times 0:1:1 --exr half --out {D}/v.mp4",
       {"{D}/v.mp4", "not EXR"}},
  };
  run_cases(root_->path(), cases);
}

}  // namespace
}  // namespace retimegs
