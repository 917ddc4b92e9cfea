// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The segmentation network RVWO ships (models/README.md): DeepLabV3 with a MobileNetV2 backbone,
// PASCAL VOC's 21 classes (15 = person), Apache-2.0, 2.8 MB, about 65 ms a frame on 2 threads.
//
// Its file is looked for, in this order: the folder $RVWO_MODEL_DIR; share/rvwo/models above the
// binary that holds this code (an installed tree, wherever it was copied); the install prefix this
// build was configured with; the source tree it was built from.
#pragma once

// OnnxSegmenterOptions' defaults are its input convention (RGB, NCHW, (x - 127.5) / 127.5, scores out).
#include <string>

namespace rvwo {

inline constexpr const char* kShippedModelFile = "deeplabv3_mnv2_voc21.onnx";
inline constexpr const char* kShippedModelLabelSet = "voc21";  // SemanticPriors::builtin's name

// The shipped model's path. Throws std::runtime_error naming every folder looked in when none has it.
std::string shippedModelPath();

}  // namespace rvwo
