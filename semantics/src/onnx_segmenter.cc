// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/semantics/onnx_segmenter.h"

#include <onnxruntime_cxx_api.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

namespace rvwo {
namespace {

std::string shapeString(const std::vector<int64_t>& shape) {
  std::ostringstream o;
  o << "[";
  for (std::size_t i = 0; i < shape.size(); ++i)
    o << (i ? ", " : "") << (shape[i] < 0 ? std::string("?") : std::to_string(shape[i]));
  o << "]";
  return o.str();
}

const char* typeName(ONNXTensorElementDataType t) {
  switch (t) {
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_FLOAT:
      return "float32";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_DOUBLE:
      return "float64";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_FLOAT16:
      return "float16";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_UINT8:
      return "uint8";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_INT8:
      return "int8";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_INT32:
      return "int32";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_INT64:
      return "int64";
    default:
      return "another type";
  }
}

// One environment per process, as ONNX Runtime recommends.
Ort::Env& env() {
  static Ort::Env e(ORT_LOGGING_LEVEL_ERROR, "rvwo");
  return e;
}

[[noreturn]] void bad(const std::string& model, const std::string& what) {
  throw std::invalid_argument("segmenter: " + model + ": " + what);
}

}  // namespace

struct OnnxSegmenter::Impl {
  OnnxSegmenterOptions o;
  std::unique_ptr<Ort::Session> session;
  std::string input_name, output_name;
  int width = 0, height = 0, classes = 0;
  ONNXTensorElementDataType output_type = ONNX_TENSOR_ELEMENT_DATA_TYPE_FLOAT;
  Ort::MemoryInfo memory = Ort::MemoryInfo::CreateCpu(OrtArenaAllocator, OrtMemTypeDefault);
  std::vector<float> input;  // reused between frames
};

OnnxSegmenter::OnnxSegmenter(const OnnxSegmenterOptions& options) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.o = options;
  const std::string& path = options.model_path;
  if (options.class_names.empty()) bad(path, "no class names given (the label set the network speaks)");
  if (options.intra_op_threads < 1) bad(path, "intra_op_threads must be >= 1");
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) bad(path, "model file not found");
  Ort::SessionOptions so;
  so.SetIntraOpNumThreads(options.intra_op_threads);
  so.SetInterOpNumThreads(1);
  so.SetGraphOptimizationLevel(GraphOptimizationLevel::ORT_ENABLE_ALL);
  try {
    m.session = std::make_unique<Ort::Session>(env(), path.c_str(), so);
  } catch (const Ort::Exception& e) {
    bad(path, std::string("not a model ONNX Runtime 1.21 can load (") + e.what() + ")");
  }
  Ort::AllocatorWithDefaultOptions alloc;
  auto pick = [&](bool input, const std::string& wanted) -> std::size_t {
    const std::size_t n = input ? m.session->GetInputCount() : m.session->GetOutputCount();
    if (n == 0) bad(path, input ? "the model has no input" : "the model has no output");
    if (wanted.empty()) return 0;
    std::string names;
    for (std::size_t i = 0; i < n; ++i) {
      const std::string name =
          input ? m.session->GetInputNameAllocated(i, alloc).get() : m.session->GetOutputNameAllocated(i, alloc).get();
      if (name == wanted) return i;
      names += (i ? ", " : "") + name;
    }
    bad(path, std::string(input ? "no input" : "no output") + " named '" + wanted + "' (it has: " + names + ")");
  };
  const std::size_t in = pick(true, options.input_name), out = pick(false, options.output_name);
  m.input_name = m.session->GetInputNameAllocated(in, alloc).get();
  m.output_name = m.session->GetOutputNameAllocated(out, alloc).get();

  // ---- input: float32, rank 4, 3 channels where the layout says, size fixed or given ----
  // The shape info is a view into its TypeInfo: keep the owner alive.
  const Ort::TypeInfo in_type = m.session->GetInputTypeInfo(in);
  const auto in_info = in_type.GetTensorTypeAndShapeInfo();
  const std::vector<int64_t> in_shape = in_info.GetShape();
  const std::string in_desc = "input '" + m.input_name + "' " + shapeString(in_shape);
  if (in_info.GetElementType() != ONNX_TENSOR_ELEMENT_DATA_TYPE_FLOAT) {
    bad(path, in_desc + " has element type " + typeName(in_info.GetElementType()) + ", expected float32");
  }
  const bool nchw = options.layout == OnnxSegmenterOptions::Layout::kNCHW;
  if (in_shape.size() != 4) {
    bad(path, in_desc + " has rank " + std::to_string(in_shape.size()) + ", expected 4 (" +
                  (nchw ? "N, C, H, W" : "N, H, W, C") + ")");
  }
  const int64_t c = nchw ? in_shape[1] : in_shape[3];
  const int64_t hh = nchw ? in_shape[2] : in_shape[1];
  const int64_t w = nchw ? in_shape[3] : in_shape[2];
  if (c != 3) {
    bad(path, in_desc + " has " + std::to_string(c) + " channels where the " + (nchw ? "NCHW" : "NHWC") +
                  " layout puts them, expected 3");
  }
  if (in_shape[0] > 1) bad(path, in_desc + " has a batch of " + std::to_string(in_shape[0]) + ", expected 1");
  auto size = [&](int64_t model, int given, const char* what) -> int {
    if (model > 0 && given > 0 && model != given) {
      bad(path,
          in_desc + " takes " + what + " " + std::to_string(model) + ", the options say " + std::to_string(given));
    }
    if (model <= 0 && given <= 0) bad(path, in_desc + " has a free " + what + ": give input_" + what);
    return model > 0 ? static_cast<int>(model) : given;
  };
  m.height = size(hh, options.input_height, "height");
  m.width = size(w, options.input_width, "width");

  // ---- output ----
  const Ort::TypeInfo out_type = m.session->GetOutputTypeInfo(out);
  const auto out_info = out_type.GetTensorTypeAndShapeInfo();
  const std::vector<int64_t> out_shape = out_info.GetShape();
  const std::string out_desc = "output '" + m.output_name + "' " + shapeString(out_shape);
  m.output_type = out_info.GetElementType();
  m.classes = static_cast<int>(options.class_names.size());
  if (options.output == OnnxSegmenterOptions::Output::kScores) {
    if (m.output_type != ONNX_TENSOR_ELEMENT_DATA_TYPE_FLOAT) {
      bad(path, out_desc + " has element type " + typeName(m.output_type) + ", expected float32 class scores");
    }
    if (out_shape.size() != 4)
      bad(path, out_desc + " has rank " + std::to_string(out_shape.size()) + ", expected 4 [1, C, h, w]");
    if (out_shape[1] > 0 && out_shape[1] != m.classes) {
      bad(path, out_desc + " scores " + std::to_string(out_shape[1]) + " classes, the label set has " +
                    std::to_string(m.classes));
    }
  } else {
    if (m.output_type != ONNX_TENSOR_ELEMENT_DATA_TYPE_INT64 && m.output_type != ONNX_TENSOR_ELEMENT_DATA_TYPE_INT32 &&
        m.output_type != ONNX_TENSOR_ELEMENT_DATA_TYPE_UINT8) {
      bad(path, out_desc + " has element type " + typeName(m.output_type) + ", expected int64, int32 or uint8 labels");
    }
    if (!(out_shape.size() == 3 || (out_shape.size() == 4 && out_shape[1] == 1))) {
      bad(path, out_desc + " is not a label map [1, h, w] or [1, 1, h, w]");
    }
  }
  if (options.confidence && options.output != OnnxSegmenterOptions::Output::kScores) {
    bad(path, "confidence needs class scores (output kScores)");
  }
  m.input.resize(static_cast<std::size_t>(3) * m.width * m.height);
}

OnnxSegmenter::~OnnxSegmenter() = default;
const std::vector<std::string>& OnnxSegmenter::classNames() const { return impl_->o.class_names; }
int OnnxSegmenter::inputWidth() const { return impl_->width; }
int OnnxSegmenter::inputHeight() const { return impl_->height; }

Segmentation OnnxSegmenter::segment(const cv::Mat& image, const FrameInfo&) {
  Impl& m = *impl_;
  const cv::Mat bgr = toBgr(image);
  cv::Mat resized;
  cv::resize(bgr, resized, cv::Size(m.width, m.height), 0, 0, cv::INTER_LINEAR);
  const bool rgb = m.o.colour_order == OnnxSegmenterOptions::ColourOrder::kRGB;
  const bool nchw = m.o.layout == OnnxSegmenterOptions::Layout::kNCHW;
  const std::size_t plane = static_cast<std::size_t>(m.width) * m.height;
  for (int y = 0; y < m.height; ++y) {
    const cv::Vec3b* row = resized.ptr<cv::Vec3b>(y);
    for (int x = 0; x < m.width; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * m.width + x;
      for (int ch = 0; ch < 3; ++ch) {
        const float v = (row[x][rgb ? 2 - ch : ch] - m.o.mean[ch]) * m.o.scale[ch];
        m.input[nchw ? ch * plane + p : 3 * p + ch] = v;
      }
    }
  }
  const std::array<int64_t, 4> shape =
      nchw ? std::array<int64_t, 4>{1, 3, m.height, m.width} : std::array<int64_t, 4>{1, m.height, m.width, 3};
  Ort::Value input = Ort::Value::CreateTensor<float>(m.memory, m.input.data(), m.input.size(), shape.data(), 4);
  const char* in_names[] = {m.input_name.c_str()};
  const char* out_names[] = {m.output_name.c_str()};
  std::vector<Ort::Value> outputs;
  try {
    outputs = m.session->Run(Ort::RunOptions{nullptr}, in_names, &input, 1, out_names, 1);
  } catch (const Ort::Exception& e) {
    throw std::runtime_error(std::string("segmenter: inference failed: ") + e.what());
  }
  const std::vector<int64_t> os = outputs[0].GetTensorTypeAndShapeInfo().GetShape();
  const int oh = static_cast<int>(os[os.size() - 2]), ow = static_cast<int>(os[os.size() - 1]);
  cv::Mat labels(oh, ow, CV_32S), confidence;
  const std::size_t opl = static_cast<std::size_t>(oh) * ow;
  if (m.o.output == OnnxSegmenterOptions::Output::kScores) {
    if (os[1] != m.classes) {
      throw std::runtime_error("segmenter: the network scored " + std::to_string(os[1]) +
                               " classes, the label set has " + std::to_string(m.classes));
    }
    const float* s = outputs[0].GetTensorData<float>();
    // Scores that are not numbers would all lose the comparison below: every pixel the first class.
    const std::size_t n = opl * static_cast<std::size_t>(m.classes);
    const std::size_t bad =
        static_cast<std::size_t>(std::count_if(s, s + n, [](float v) { return !std::isfinite(v); }));
    if (bad > 0)
      throw std::runtime_error("segmenter: " + std::to_string(bad) + " of the network's " + std::to_string(n) +
                               " scores are not finite numbers: no labels from it");
    if (m.o.confidence) confidence.create(oh, ow, CV_32F);
    for (std::size_t p = 0; p < opl; ++p) {
      int best = 0;
      float top = s[p];
      for (int k = 1; k < m.classes; ++k) {
        const float v = s[k * opl + p];
        if (v > top) top = v, best = k;
      }
      labels.at<int>(static_cast<int>(p)) = best;
      if (m.o.confidence) {
        double sum = 0;
        for (int k = 0; k < m.classes; ++k) sum += std::exp(static_cast<double>(s[k * opl + p] - top));
        confidence.at<float>(static_cast<int>(p)) = static_cast<float>(1.0 / sum);
      }
    }
  } else {
    for (std::size_t p = 0; p < opl; ++p) {
      int64_t v = 0;
      if (m.output_type == ONNX_TENSOR_ELEMENT_DATA_TYPE_INT64) v = outputs[0].GetTensorData<int64_t>()[p];
      if (m.output_type == ONNX_TENSOR_ELEMENT_DATA_TYPE_INT32) v = outputs[0].GetTensorData<int32_t>()[p];
      if (m.output_type == ONNX_TENSOR_ELEMENT_DATA_TYPE_UINT8) v = outputs[0].GetTensorData<uint8_t>()[p];
      labels.at<int>(static_cast<int>(p)) = (v >= 0 && v < m.classes) ? static_cast<int>(v) : -1;
    }
  }
  Segmentation out;
  cv::resize(labels, out.labels, image.size(), 0, 0, cv::INTER_NEAREST);
  if (!confidence.empty()) cv::resize(confidence, out.confidence, image.size(), 0, 0, cv::INTER_LINEAR);
  return out;
}

}  // namespace rvwo
