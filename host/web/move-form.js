"use strict";
// The live page's move, built from the board's dictionary (GET
// /api/describe: `describe` in docs/protocol.md): one field per argument
// `move_to` takes, with the board's units, ranges and defaults, and the
// board's own checks applied before anything is sent.

/// Why the board would refuse `value` for argument `a`, or null.
function moveArgumentRefusal(a, value) {
  if (a.type === "flag") return typeof value === "boolean" ? null : "expected true or false";
  if (a.type === "choice") return a.choices.includes(value) ? null : `${value}; allowed: ${a.choices.join(", ")}`;
  if (typeof value !== "number" || Number.isNaN(value)) return "expected a number";
  if (a.type === "integer" && (value < 0 || !Number.isInteger(value))) return "expected an unsigned integer";
  const low = a.min === null ? -Infinity : a.min, high = a.max === null ? Infinity : a.max;
  const above = a.min_open ? value > low : value >= low;
  const below = a.max_open ? value < high : value <= high;
  if (above && below) return null;
  const unit = a.unit ? " " + a.unit : "";
  const interval = `${a.min_open ? "(" : "["}${low}, ${high}${a.max_open ? ")" : "]"}`;
  return `${value}${unit} is beyond the board's limits; allowed: ${interval}${unit}` + (a.limit ? ` (the board's ${a.limit} is ${high}${unit})` : "");
}

/// The form's inputs, one per argument, in `container`; returns a function
/// that reads them into {args} or {refusal: "KEY: why"}.
function buildMoveForm(container, args) {
  for (const a of args) {
    const label = document.createElement("label");
    label.title = a.doc;
    label.append(` ${a.name}${a.unit ? " [" + a.unit + "]" : ""} `);
    let input;
    if (a.type === "choice" || a.type === "flag") {
      input = document.createElement("select");
      const options = a.type === "flag" ? ["true", "false"] : a.choices;
      for (const name of ["", ...options]) input.add(new Option(name === "" ? "(board's default)" : name, name));
      if (a.default !== null) input.value = String(a.default);
    } else {
      input = document.createElement("input");
      input.type = "number";
      input.step = "any";
      input.size = 8;
      if (a.default !== null) input.value = String(a.default);
      else input.placeholder = a.required ? "required" : "board's default";
    }
    input.id = "move-" + a.name;
    label.append(input);
    container.append(label);
  }
  return () => {
    const request = {};
    for (const a of args) {
      const entered = document.getElementById("move-" + a.name).value;
      if (entered === "") {
        if (a.required) return { refusal: `${a.name}: missing` };
        continue;
      }
      const value = a.type === "flag" ? entered === "true" : a.type === "choice" ? entered : Number(entered);
      const refusal = moveArgumentRefusal(a, value);
      if (refusal) return { refusal: `${a.name}: ${refusal}` };
      request[a.name] = value;
    }
    return { args: request };
  };
}
