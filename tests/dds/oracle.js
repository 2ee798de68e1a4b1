// The independent ROS 2 serializer of the wire test (docs/ROS2.md): npm
// @foxglove/rosmsg2-serialization with the message definitions of ROS 2 Humble
// (@foxglove/rosmsg-msgs-common) and vision_msgs 4.x (parsed by @foxglove/rosmsg).
// stdin: {"cases": [{"type": "sensor_msgs/Image", "msg": {...}, "cdr": "hex"}]}
// stdout: {"results": [{"cdr": "hex of msg serialized", "decoded": cdr decoded}]}
"use strict";
const { MessageWriter, MessageReader } = require("@foxglove/rosmsg2-serialization");
const { parse } = require("@foxglove/rosmsg");
const { ros2humble } = require("@foxglove/rosmsg-msgs-common");

// vision_msgs 4.x (Humble/Jazzy), not in msgs-common: the .msg files as published.
const VISION = {
  "vision_msgs/Point2D": "float64 x\nfloat64 y\n",
  "vision_msgs/Pose2D": "vision_msgs/Point2D position\nfloat64 theta\n",
  "vision_msgs/BoundingBox2D": "vision_msgs/Pose2D center\nfloat64 size_x\nfloat64 size_y\n",
  "vision_msgs/ObjectHypothesis": "string class_id\nfloat64 score\n",
  "vision_msgs/ObjectHypothesisWithPose":
    "vision_msgs/ObjectHypothesis hypothesis\ngeometry_msgs/PoseWithCovariance pose\n",
  "vision_msgs/Detection2D":
    "std_msgs/Header header\nvision_msgs/ObjectHypothesisWithPose[] results\n" +
    "vision_msgs/BoundingBox2D bbox\nstring id\n",
  "vision_msgs/Detection2DArray": "std_msgs/Header header\nvision_msgs/Detection2D[] detections\n",
};

function lookup(name) {
  if (VISION[name] !== undefined) {
    const def = parse(VISION[name], { ros2: true, skipTypeFixup: true })[0];
    return { ...def, name };
  }
  const def = ros2humble[name];
  if (def === undefined) throw new Error(`no definition for ${name}`);
  return def;
}

// The root definition first, then every type it uses.
function definitions(root) {
  const out = [];
  const seen = new Set();
  const visit = (name) => {
    if (seen.has(name)) return;
    seen.add(name);
    const def = lookup(name);
    out.push(def);
    for (const f of def.definitions)
      if (f.isComplex === true && !f.isConstant) visit(f.type);
  };
  visit(root);
  return out;
}

const hex = (bytes) => Buffer.from(bytes.buffer, bytes.byteOffset, bytes.byteLength).toString("hex");
const plain = (_key, value) => (ArrayBuffer.isView(value) ? Array.from(value) : value);

function toTyped(value, name) {
  // uint8[] as Uint8Array, as ROS 2 tools pass byte arrays.
  const def = lookup(name);
  const out = { ...value };
  for (const f of def.definitions) {
    if (f.isConstant || out[f.name] === undefined) continue;
    if (f.isComplex) {
      out[f.name] = f.isArray ? out[f.name].map((v) => toTyped(v, f.type)) : toTyped(out[f.name], f.type);
    } else if (f.isArray && (f.type === "uint8" || f.type === "byte")) {
      out[f.name] = Uint8Array.from(out[f.name]);
    }
  }
  return out;
}

let input = "";
process.stdin.on("data", (d) => (input += d));
process.stdin.on("end", () => {
  const { cases } = JSON.parse(input);
  const results = cases.map((c) => {
    const defs = definitions(c.type);
    const cdr = hex(new MessageWriter(defs).writeMessage(toTyped(c.msg, c.type)));
    const decoded = c.cdr ? new MessageReader(defs).readMessage(Buffer.from(c.cdr, "hex")) : null;
    return { cdr, decoded };
  });
  process.stdout.write(JSON.stringify({ results }, plain));
});
