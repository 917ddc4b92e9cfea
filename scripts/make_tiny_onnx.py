#!/usr/bin/env python3
"""Writes the tiny ONNX models the segmentation tests use (tests/semantics/data/), a few hundred
bytes each. Their outputs are known exactly: class c's score at a pixel is the normalised value of
colour channel c, so a red pixel is class 0, green class 1, blue class 2.

  tiny_scores.onnx     input "image" float32 [1, 3, 8, 8] (NCHW, RGB) -> "scores" float32 [1, 3, 8, 8]
  tiny_labels.onnx     the same, then ArgMax -> "labels" int64 [1, 8, 8]
  tiny_nhwc.onnx       input float32 [1, 8, 8, 3] (NHWC) -> "scores" [1, 3, 8, 8]
  tiny_int_input.onnx  input int32 (a wrong element type, for the error test)
  tiny_rank3.onnx      input float32 [3, 8, 8] (a wrong rank, for the error test)
  tiny_nan.onnx        as tiny_scores, but class 0's weight is NaN: every score of it is NaN

Needs the `onnx` Python package (developers only: the generated files are committed).
ONNX Runtime 1.21 reads IR version <= 10; these use IR 8, opset 13.
Run: python3 scripts/make_tiny_onnx.py
"""
import os

import onnx
from onnx import TensorProto, helper

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "semantics", "data")


def identity_conv(input_name, output_name, first=1.0):
    w = helper.make_tensor("w", TensorProto.FLOAT, [3, 3, 1, 1], [first, 0, 0, 0, 1, 0, 0, 0, 1])
    node = helper.make_node("Conv", [input_name, "w"], [output_name], kernel_shape=[1, 1])
    return node, w


def save(graph, name):
    model = helper.make_model(graph, producer_name="rvwo make_tiny_onnx.py",
                              opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, os.path.join(OUT, name))
    print(name, os.path.getsize(os.path.join(OUT, name)), "bytes")


def main():
    os.makedirs(OUT, exist_ok=True)
    image = helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, 8, 8])
    scores = helper.make_tensor_value_info("scores", TensorProto.FLOAT, [1, 3, 8, 8])
    conv, w = identity_conv("image", "scores")
    save(helper.make_graph([conv], "tiny_scores", [image], [scores], [w]), "tiny_scores.onnx")

    labels = helper.make_tensor_value_info("labels", TensorProto.INT64, [1, 8, 8])
    conv, w = identity_conv("image", "s")
    argmax = helper.make_node("ArgMax", ["s"], ["labels"], axis=1, keepdims=0)
    save(helper.make_graph([conv, argmax], "tiny_labels", [image], [labels], [w]), "tiny_labels.onnx")

    nhwc = helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 8, 8, 3])
    transpose = helper.make_node("Transpose", ["image"], ["nchw"], perm=[0, 3, 1, 2])
    conv, w = identity_conv("nchw", "scores")
    save(helper.make_graph([transpose, conv], "tiny_nhwc", [nhwc], [scores], [w]), "tiny_nhwc.onnx")

    int_in = helper.make_tensor_value_info("image", TensorProto.INT32, [1, 3, 8, 8])
    cast = helper.make_node("Cast", ["image"], ["f"], to=TensorProto.FLOAT)
    conv, w = identity_conv("f", "scores")
    save(helper.make_graph([cast, conv], "tiny_int_input", [int_in], [scores], [w]), "tiny_int_input.onnx")

    rank3 = helper.make_tensor_value_info("image", TensorProto.FLOAT, [3, 8, 8])
    unsq = helper.make_node("Unsqueeze", ["image", "axes"], ["x4"])
    axes = helper.make_tensor("axes", TensorProto.INT64, [1], [0])
    conv, w = identity_conv("x4", "scores")
    save(helper.make_graph([unsq, conv], "tiny_rank3", [rank3], [scores], [w, axes]), "tiny_rank3.onnx")

    conv, w = identity_conv("image", "scores", first=float("nan"))
    save(helper.make_graph([conv], "tiny_nan", [image], [scores], [w]), "tiny_nan.onnx")


if __name__ == "__main__":
    main()
