// bench_pipeline's study 2: disparity, ours (DisparityPipeline with and without its post-filters,
// BM and SGBM, the parallel right-to-left matcher) against OpenCV's matchers alone and
// stereo_image_proc's processDisparity, interleaved frame by frame; where the allocations come
// from.
#include "bench.h"

#include "stereo_safety_map/ros/conversions.h"

#include <functional>
#include <memory>
#include <stdexcept>

namespace bench {

void studyDisparity(Bench* b) {
  const Options& opt = b->opt;
  auto& head = b->head;
  auto& measured = b->measured;
  auto& pcfg = b->pcfg;
  auto& start_mask = b->start_mask;
  auto& reg = b->reg;
  auto& comparisons = b->comparisons;
  auto& pending = b->pending;
  auto& density = b->density;
  auto& disparity_allocs = b->disparity_allocs;
  // ---- 2. disparity: ours vs OpenCV alone vs stereo_image_proc ----------------------------------
  {
    progress("disparity: %zu frames x %d passes", measured.size(), opt.passes);
    ssm::DisparityPipelineConfig bm_cfg = pcfg.disparity;  // package defaults: BM + all filters
    ssm::DisparityPipelineConfig bare_cfg = bm_cfg;
    bare_cfg.enable_texture = bare_cfg.enable_left_right = false;
    bare_cfg.enable_neighbour_consistency = bare_cfg.enable_spike_removal = false;
    ssm::DisparityPipelineConfig sgbm_cfg = bm_cfg;  // `matcher: sgbm`, every other default kept
    sgbm_cfg.matcher = ssm::StereoMatcherType::kSemiGlobal;

    struct Variant {
      std::string id, label, impl;
      std::function<void(const Frame&, cv::Mat*)> run;  // output: float disparity for density
    };
    std::vector<Variant> variants;
    auto ours = [&](const ssm::DisparityPipelineConfig& c) {
      auto p = std::make_shared<ssm::DisparityPipeline>(c);
      auto stats = std::make_shared<ssm::DisparityStats>();
      auto buf = std::make_shared<cv::Mat>();
      return std::function<void(const Frame&, cv::Mat*)>(
          [p, stats, buf](const Frame& f, cv::Mat* out) {
            std::string e;
            if (!p->compute(f.left, f.right, out != nullptr ? out : buf.get(), stats.get(), &e))
              throw std::runtime_error("DisparityPipeline: " + e);
          });
    };
    auto raw = [&](const ssm::DisparityPipelineConfig& c) {
      auto m = ssm::DisparityPipeline::matcherFor(c);
      auto buf = std::make_shared<cv::Mat>();
      return std::function<void(const Frame&, cv::Mat*)>([m, buf](const Frame& f, cv::Mat* out) {
        m->compute(f.left, f.right, *buf);
        if (out != nullptr) buf->convertTo(*out, CV_32F, 1.0 / cv::StereoMatcher::DISP_SCALE);
      });
    };
    // Pipeline objects kept outside the lambdas so that per-step stats can be read.
    ssm::DisparityPipeline ours_bm(bm_cfg);
    ssm::DisparityStats ours_bm_stats;
    cv::Mat ours_bm_out;
    variants.push_back({"disp.ours_bm", "ours: DisparityPipeline BM + all filters", "ours",
                        [&](const Frame& f, cv::Mat* out) {
                          std::string e;
                          if (!ours_bm.compute(f.left, f.right, out != nullptr ? out : &ours_bm_out,
                                               &ours_bm_stats, &e))
                            throw std::runtime_error("DisparityPipeline: " + e);
                        }});
    // The same with the right-to-left matcher on the pipeline's helper thread. The helper is
    // created at the first call and inherits this thread's core mask, so that call runs with
    // every core allowed: the measuring thread stays on its core, the helper may use another.
    // Thread CPU counts the measuring thread only: the wall time is the figure to read.
    ssm::DisparityPipelineConfig par_cfg = bm_cfg;
    par_cfg.parallel_left_right = true;
    ssm::DisparityPipeline ours_par(par_cfg);
    // The same for SGBM: its second full matcher beside the first (issue 18), same output.
    ssm::DisparityPipelineConfig sgbm_par_cfg = par_cfg;
    sgbm_par_cfg.matcher = ssm::StereoMatcherType::kSemiGlobal;
    ssm::DisparityPipeline ours_sgbm_par(sgbm_par_cfg);
    {
      cpu_set_t pinned_mask;
      CPU_ZERO(&pinned_mask);
      sched_getaffinity(0, sizeof(pinned_mask), &pinned_mask);
      sched_setaffinity(0, sizeof(start_mask), &start_mask);
      cv::Mat d;
      std::string e;
      ours_par.compute(measured.front().left, measured.front().right, &d, nullptr, &e);
      ours_sgbm_par.compute(measured.front().left, measured.front().right, &d, nullptr, &e);
      sched_setaffinity(0, sizeof(pinned_mask), &pinned_mask);
    }
    cv::Mat ours_par_out;
    variants.push_back({"disp.ours_bm_parallel",
                        "ours: BM + all filters, right-to-left matcher on a second thread "
                        "(parallel_left_right; CPU: measuring thread only)",
                        "ours", [&](const Frame& f, cv::Mat* out) {
                          std::string e;
                          if (!ours_par.compute(f.left, f.right,
                                                out != nullptr ? out : &ours_par_out, nullptr, &e))
                            throw std::runtime_error("DisparityPipeline: " + e);
                        }});
    variants.push_back({"disp.ours_bm_nofilters",
                        "ours: DisparityPipeline BM, filters off (matcher + float conversion)",
                        "ours", ours(bare_cfg)});
    variants.push_back(
        {"disp.opencv_bm", "OpenCV StereoBM::compute alone (same settings)", "peer", raw(bm_cfg)});
#if SSM_BENCH_HAVE_SIP
    std::string sip_why;
    const SipProcessDisparity sip_fn = loadSip(&sip_why);
    auto sip = [&](const ssm::DisparityPipelineConfig& c, bool own_filters) {
      auto p = std::make_shared<stereo_image_proc::StereoProcessor>();
      configureSip(p.get(), c, own_filters);
      auto model = std::make_shared<image_geometry::StereoCameraModel>();
      model->fromCameraInfo(ssm::toCameraInfo(ds::stereoCameraModel(head), false),
                            ssm::toCameraInfo(ds::stereoCameraModel(head), true));
      auto msg = std::make_shared<stereo_msgs::DisparityImage>();
      return std::function<void(const Frame&, cv::Mat*)>(
          [p, model, msg, sip_fn](const Frame& f, cv::Mat* out) {
            sip_fn(p.get(), f.left, f.right, *model, *msg);
            if (out != nullptr) {
              const sensor_msgs::Image& im = msg->image;
              cv::Mat(static_cast<int>(im.height), static_cast<int>(im.width), CV_32FC1,
                      const_cast<std::uint8_t*>(im.data.data()), im.step)
                  .copyTo(*out);
            }
          });
    };
    if (sip_fn != nullptr) {
      variants.push_back({"disp.sip_bm",
                          "stereo_image_proc StereoProcessor::processDisparity, BM, same settings",
                          "peer", sip(bm_cfg, false)});
      variants.push_back({"disp.sip_bm_own_filters",
                          "stereo_image_proc BM + its own filters (texture 10, speckle 100/4)",
                          "peer", sip(bm_cfg, true)});
    } else {
      pending.push_back("stereo_image_proc disparity peer: " + sip_why);
    }
#else
    const bool sip_fn = false;
    pending.push_back(
        "stereo_image_proc disparity peer: stereo_image_proc/processor.h not installed "
        "(Debian libstereo-image-proc-dev)");
#endif
    variants.push_back(
        {"disp.ours_sgbm", "ours: DisparityPipeline SGBM + all filters", "ours", ours(sgbm_cfg)});
    // Issue 18: the left-right check's other modes (not bit for bit the default).
    cv::Mat ours_sgbm_par_out;
    variants.push_back({"disp.ours_sgbm_parallel",
                        "ours: SGBM + all filters, right-to-left matcher on a second thread "
                        "(parallel_left_right; CPU: measuring thread only)",
                        "ours", [&](const Frame& f, cv::Mat* out) {
                          std::string e;
                          if (!ours_sgbm_par.compute(f.left, f.right,
                                                     out != nullptr ? out : &ours_sgbm_par_out,
                                                     nullptr, &e))
                            throw std::runtime_error("DisparityPipeline: " + e);
                        }});
    ssm::DisparityPipelineConfig sgbm_half_cfg = sgbm_cfg;
    sgbm_half_cfg.left_right_mode = ssm::LeftRightMode::kHalfResolution;
    variants.push_back({"disp.ours_sgbm_half",
                        "ours: SGBM + all filters, left_right_mode half (right-to-left match at "
                        "half resolution)",
                        "ours", ours(sgbm_half_cfg)});
    ssm::DisparityPipelineConfig sgbm_opencv_cfg = sgbm_cfg;
    sgbm_opencv_cfg.left_right_mode = ssm::LeftRightMode::kOpenCV;
    variants.push_back({"disp.ours_sgbm_opencv",
                        "ours: SGBM + all filters, left_right_mode opencv (no second match)",
                        "ours", ours(sgbm_opencv_cfg)});
    variants.push_back({"disp.opencv_sgbm", "OpenCV StereoSGBM::compute alone (same settings)",
                        "peer", raw(sgbm_cfg)});
#if SSM_BENCH_HAVE_SIP
    if (sip_fn != nullptr) {
      variants.push_back({"disp.sip_sgbm",
                          "stereo_image_proc processDisparity, SGBM, same settings", "peer",
                          sip(sgbm_cfg, false)});
    }
#endif
    for (const Variant& v : variants)
      reg.get(v.id, "disparity 640x480, 64 disparities, block 9", v.label, v.impl);
    cv::Mat out;
    for (const Variant& v : variants)
      v.run(measured.front(), &out);  // warm-up: matchers and buffers
    for (int pass = 0; pass < opt.passes; ++pass) {
      for (const Frame& f : measured) {
        for (const Variant& v : variants) {
          Series& s = reg.get(v.id, "", "", "");
          s.add(measure([&] { v.run(f, nullptr); }));
          if (v.id == "disp.ours_bm") {
            for (int st = 0; st < ssm::kNumDisparitySteps; ++st) {
              const ssm::DisparityStepStats& ss = ours_bm_stats.steps[st];
              if (!ss.ran) continue;
              const char* name = ssm::disparityStepName(static_cast<ssm::DisparityStep>(st));
              reg.get(std::string("disp.ours_bm.step.") + name, "disparity steps (ours, BM)",
                      std::string("step: ") + name, "ours", "wall time from DisparityStats")
                  .addWall(ss.ms);
            }
          }
        }
      }
    }
    for (const Variant& v : variants) {  // output density, outside the timing
      v.run(measured.front(), &out);
      density[v.id].push_back(validFraction(out));
    }
    // Where DisparityPipeline's per-frame allocations come from: the bare matcher, then each
    // post-filter alone on top of it (third call on the same frame, after two warm-ups).
    {
      auto allocsWith = [&](const std::function<void(ssm::DisparityPipelineConfig*)>& enable) {
        ssm::DisparityPipelineConfig c = bare_cfg;
        enable(&c);
        ssm::DisparityPipeline p(c);
        cv::Mat d;
        std::string e;
        p.compute(measured.front().left, measured.front().right, &d, nullptr, &e);
        p.compute(measured.front().left, measured.front().right, &d, nullptr, &e);
        return measure(
            [&] { p.compute(measured.front().left, measured.front().right, &d, nullptr, &e); });
      };
      const std::pair<const char*, std::function<void(ssm::DisparityPipelineConfig*)>> steps[] = {
          {"matcher only", [](ssm::DisparityPipelineConfig*) {}},
          {"+ texture", [](ssm::DisparityPipelineConfig* c) { c->enable_texture = true; }},
          {"+ left-right (2nd matcher)",
           [](ssm::DisparityPipelineConfig* c) { c->enable_left_right = true; }},
          {"+ neighbour consistency",
           [](ssm::DisparityPipelineConfig* c) { c->enable_neighbour_consistency = true; }},
          {"+ spike removal",
           [](ssm::DisparityPipelineConfig* c) { c->enable_spike_removal = true; }},
      };
      for (const auto& st : steps) {
        const Sample a = allocsWith(st.second);
        disparity_allocs.push_back({st.first, a});
      }
    }
    comparisons.push_back({"disp.ours_bm", "disp.opencv_bm", "disparity BM + filters"});
    comparisons.push_back({"disp.ours_bm_nofilters", "disp.opencv_bm", "disparity BM, no filters"});
    comparisons.push_back({"disp.ours_sgbm", "disp.opencv_sgbm", "disparity SGBM + filters"});
    comparisons.push_back(
        {"disp.ours_sgbm_half", "disp.opencv_sgbm", "disparity SGBM + filters, left-right half"});
    comparisons.push_back({"disp.ours_sgbm_parallel", "disp.opencv_sgbm",
                           "disparity SGBM + filters, right-to-left on a second thread (wall)"});
    comparisons.push_back({"disp.ours_sgbm_opencv", "disp.opencv_sgbm",
                           "disparity SGBM + filters, left-right opencv"});
    if (sip_fn) {
      comparisons.push_back({"disp.ours_bm", "disp.sip_bm", "disparity BM + filters"});
      comparisons.push_back({"disp.ours_bm", "disp.sip_bm_own_filters", "disparity BM + filters"});
      comparisons.push_back({"disp.ours_bm_nofilters", "disp.sip_bm", "disparity BM, no filters"});
      comparisons.push_back({"disp.ours_sgbm", "disp.sip_sgbm", "disparity SGBM + filters"});
    }
  }
  pending.push_back(
      "stereo_image_proc through ROS (its disparity nodelet with message transport and "
      "cv_bridge), the ROS replay at 30 Hz (latency, drops) and the nodelet manager's memory: "
      "scripts/bench --ros");
}

}  // namespace bench
