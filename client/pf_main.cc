// pf: the PointForward command line. Parses the subcommand and hands the rest
// of the words to it; see `pf help`. With `--server ADDR` first (or PF_SERVER
// set) the scene, render and jobs commands go to a pf-server instead
// (client/remote/).
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/remote/remote_main.h"
#include "common/logging.h"
#include "common/memory_reuse.h"

namespace pf {

namespace {

constexpr char kUsage[] = R"(pf: the PointForward render service command line

usage: pf <command> [args]

commands:
  synth --out DIR [--seed N] [--cameras N] [--frames N] [--width W --height H]
        [--antialias N] [--lens pinhole|ftheta]
        write a procedural driving clip with ground truth (ftheta: f-theta
        cameras 120 degrees across)
  synth render --clip DIR --cameras VIEWS.json --out DIR2
        ray-cast true images and depths of a synth clip at any views
  validate CLIP.json [--allow-outside-paths]
        check a clip manifest; one summary line, or every problem
  import waymo SEGMENT.tfrecord --out DIR [--cameras A,B] [--start-us T --duration-us D]
              [--roles paper|all-context|alternate]
  import dgp SCENE_DIR --out DIR [--cameras A,B] [--start-us T --duration-us D]
              [--roles paper|all-context|alternate]
  import pandaset SEQ_DIR --out DIR [--cameras A,B] [--frames A:B] [--scale S]
              [--roles paper|all-context|alternate]
        turn a driving log into a clip; any of them [--lidar-as-depth-maps]: the
        LiDAR as a sparse depth map per frame (depth/) instead of sweeps
  scene info SCENE | scene export SCENE --ply OUT.ply [--time-us T]
        inspect or export a Gaussian scene
  render SCENE --cameras VIEWS.json --out DIR [--outputs rgb,alpha,depth,features,instance,filled]
        [--device cpu|cuda:N]
        render EXR files and PNG previews of a scene (on the CPU or a GPU), and the
        LiDAR sweeps VIEWS.json lists (lidars: range image EXR and point record)
  lidar spec SWEEP.bin [--origin X,Y,Z] [--min-range M] [--max-range M]
        estimate a spinning LiDAR's beams from a recorded sweep; prints a LidarSpec
  bench raster [--gaussians N] [--width W --height H] [--channels C] [--repeat R] [--seed S]
        [--device cpu|cuda:N] [--compare-cpu] [--backward]
        time the rasterizer (and, with --backward, its backward pass on the CPU); prints JSON
  bench reconstruct CLIP.json [--repeat N] [the flags of reconstruct but --out]
        reconstruct the clip N times (default 3); prints the median time of each stage,
        the Gaussians and the peak memory as JSON
  reconstruct CLIP.json --out SCENE [--model analytic|pixel-aligned] [--ns N --nd N]
        [--fusion softmax|average|no-depth] [--lifespan] [--refine N] [--splat-sigma S]
        [--low-pass PX2] [--order-band B] [--fade-frames F] [--hidden-band PX] [--colour-fit-memory GB]
        [--no-ground-fill] [--no-facades] [--no-stereo] [--no-ego-layer] [--render-blur PX] [--render-blur-growth G] [--still-rig-density F] [--device cpu|cuda[:N]]
        [--colour gradients|flat] [--working-space srgb|linear] [--completion nearest|ip-basic]
        [--optimize-steps N [--optimize-seconds S] [--optimize-poses] [--optimize-densify]]
        [--allow-outside-paths]
        check the clip as validate does, build a Gaussian scene from its CONTEXT frames
  eval CLIP.json --out DIR [--model ...] [same flags as reconstruct]
       [--views VIEWS.json --truth DIR2] [--lane-shift D1,D2,... --lane-shift-time-us T]
        reconstruct, render the TARGET frames (and extra or lane-shifted views), write
        DIR/report.json and contact sheets; pf eval --help for the details
  depth-eval CLIP.json [--hide half|top] [--top-share F] [--json FILE] [--completion ...]
             [--no-ground-fill] [--no-facades] [--no-stereo]
        hide part of the LiDAR from the depth stage and measure each method's dense
        depth at the hidden points; pf depth-eval --help for the details
  help  this text; pf COMMAND --help shows one command's lines

remote mode: pf --server HOST:PORT <command> (or PF_SERVER=HOST:PORT, which sends
scene, render and jobs to that server; other commands always run here).
Before the command: [--tls-ca PEM] (TLS; or PF_TLS_CA) [--tls-cert PEM --tls-key PEM]
(mutual TLS; or PF_TLS_CERT, PF_TLS_KEY) [--token-file PATH] (bearer token; else
the token in PF_TOKEN):
  scene create CLIP.json|file:///abs/clip.json [--wait] [--model M] [--ns N] [--nd N]
        [--fusion F] [--lifespan] [--device D] [--request-id ID] [TUNING]
        upload the clip and every file it names (or let the server read a file://
        clip), start its reconstruction; prints the operation name. --wait waits
        and prints the scene
  scene get NAME | scene list [--page-size N] | scene delete NAME
  scene export NAME --ply OUT.ply [--time-us T]
        inspect, list, delete scenes; export one as a 3DGS PLY (sha256 checked)
  render SCENE --cameras VIEWS.json [--out DIR --wait] [--outputs LIST]
         [--chunk-frames N] [--request-id ID]
  render --clip CLIP.json [--model M] [--ns N] [--nd N] [--fusion F] [--lifespan]
         [--device D] [TUNING] --cameras VIEWS.json [--out DIR --wait] [--outputs LIST]
        submit a render job (of a clip: reconstructed first unless cached);
        TUNING: [--refine N] [--splat-sigma S] [--low-pass PX2] [--order-band B] [--fade-frames F] [--hidden-band PX]
        [--colour-fit-memory GB] [--no-ground-fill] [--no-facades] [--no-stereo] [--no-ego-layer] [--render-blur PX] [--render-blur-growth G] [--still-rig-density F] [--colour gradients|flat]
        [--completion M] [--working-space srgb|linear]
        [--optimize-steps N [--optimize-seconds S] [--optimize-poses] [--optimize-densify]],
        as pf reconstruct's
        (unset: the worker's defaults; a scene made with other values is another scene);
        --wait waits and downloads every output file into DIR
  jobs list [--kind reconstruct|render] | jobs get ID | jobs cancel ID
  jobs wait ID [--out DIR]
        the server's jobs; ID is operations/X, renderJobs/X or X. wait shows a
        progress bar (plain lines when stderr is not a terminal); --out
        downloads a render job's files

Exit codes: 0 done, 1 failed, 2 bad input, 3 server unreachable.
Set PF_LOG_LEVEL=debug for more logging, PF_THREADS=N to size the thread pool.
)";

// Returns the lines of kUsage's local commands that describe `command`: each
// entry (a line indented by two spaces, with the more indented lines after
// it) that starts with the command's name.
std::string UsageOf(const std::string& command) {
  const std::string_view usage = kUsage;
  const size_t begin = usage.find("commands:\n");
  const size_t end = usage.find("\nremote mode:");
  std::string out, entry;
  bool keep = false;
  auto flush = [&] {
    if (keep) out += entry;
    entry.clear();
  };
  for (std::string_view rest = usage.substr(begin, end - begin); !rest.empty();) {
    const size_t newline = rest.find('\n');
    const std::string_view line =
        rest.substr(0, newline == std::string_view::npos ? rest.size() : newline + 1);
    rest.remove_prefix(line.size());
    if (line.size() > 2 && line.substr(0, 2) == "  " && line[2] != ' ') {
      flush();
      const std::string_view words = line.substr(2);
      keep = words.substr(0, command.size()) == command &&
             (words.size() == command.size() || words[command.size()] == ' ');
    }
    entry += line;
  }
  flush();
  return out;
}

}  // namespace
}  // namespace pf

int main(int argc, char** argv) {
  // Reconstruction frees and allocates gigabytes; reusing the freed memory
  // saves its page faults (common/memory_reuse.h).
  pf::KeepFreedMemoryForReuse();
  pf::InitLogging();
  // Remote mode: a leading --server ADDR, or PF_SERVER for the remote commands.
  if (const std::optional<int> code =
          pf::RunRemoteIfAsked(std::vector<std::string>(argv + 1, argv + argc))) {
    return *code;
  }
  if (argc < 2 || std::strcmp(argv[1], "help") == 0 || std::strcmp(argv[1], "--help") == 0 ||
      std::strcmp(argv[1], "-h") == 0) {
    std::fputs(pf::kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? pf::kExitBadInput : pf::kExitOk;
  }
  const std::string command = argv[1];
  const std::vector<std::string> args(argv + 2, argv + argc);
  // pf COMMAND --help: that command's lines of pf help (pf eval has its own).
  if (command != "eval" && command != "depth-eval" &&
      std::any_of(args.begin(), args.end(),
                  [](const std::string& a) { return a == "--help" || a == "-h"; })) {
    const std::string usage = pf::UsageOf(command);
    if (!usage.empty()) {
      std::printf(
          "usage:\n%s\nExit codes: 0 done, 1 failed, 2 bad input. pf help lists every command.\n",
          usage.c_str());
      return pf::kExitOk;
    }
  }
  if (command == "validate") return pf::RunValidate(args);
  if (command == "synth") return pf::RunSynth(args);
  if (command == "import") return pf::RunImport(args);
  if (command == "scene") return pf::RunScene(args);
  if (command == "render") return pf::RunRender(args);
  if (command == "bench") return pf::RunBench(args);
  if (command == "reconstruct") return pf::RunReconstruct(args);
  if (command == "eval") return pf::RunEval(args);
  if (command == "depth-eval") return pf::RunDepthEval(args);
  if (command == "lidar") return pf::RunLidar(args);
  if (command == "jobs") {
    std::fputs("pf jobs: talks to a server: give --server HOST:PORT first or set PF_SERVER\n",
               stderr);
    return pf::kExitBadInput;
  }
  std::fprintf(stderr, "pf: unknown command '%s' (see pf help)\n", command.c_str());
  return pf::kExitBadInput;
}
