// Small helpers the page's modules share: colours, ID lists, times, DOM building.

// One colour per actor, by the actor's index in the script (stable while the script runs),
// chosen to stay apart from each other on the dark map.
const PALETTE = [
  "#4cc9f0", "#f72585", "#b8f35d", "#ffb703", "#9b5de5", "#00f5d4",
  "#fb8500", "#ff595e", "#8ac926", "#6a8cff", "#ffca3a", "#e0aaff",
];

export function colour(index) {
  return index < 0 ? "#6b7785" : PALETTE[index % PALETTE.length];
}

/** Colour of the actor called `name` given the actor names in order. */
export function actorColour(names, name) {
  return colour(names.indexOf(name));
}

/** [1,2,3,5] -> "1-3,5" (the command line's platform lists). */
export function idRanges(ids) {
  const sorted = [...ids].sort((a, b) => a - b);
  const parts = [];
  for (let i = 0; i < sorted.length; ) {
    let j = i;
    while (j + 1 < sorted.length && sorted[j + 1] === sorted[j] + 1) j++;
    parts.push(i === j ? `${sorted[i]}` : `${sorted[i]}-${sorted[j]}`);
    i = j + 1;
  }
  return parts.join(",");
}

/** Seconds as the header and lists show them: 75.3 -> "1:15.3". */
export function clock(seconds) {
  if (seconds == null || !isFinite(seconds)) return "—";
  const s = Math.max(0, seconds);
  const m = Math.floor(s / 60);
  const rest = (s - m * 60).toFixed(1);
  return m > 0 ? `${m}:${rest.padStart(4, "0")}` : `${rest} s`;
}

/** An element: el("li", {class: "x", dataset: {a: 1}}, "text", child...). */
export function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs)) {
    if (value == null || value === false) continue;
    if (key === "dataset") Object.assign(node.dataset, value);
    else if (key === "style") node.style.cssText = value;
    else if (key === "class") node.className = value;
    else if (key.startsWith("on")) node.addEventListener(key.slice(2), value);
    else node.setAttribute(key, value === true ? "" : value);
  }
  for (const child of children) {
    if (child == null || child === false) continue;
    node.append(child instanceof Node ? child : String(child));
  }
  return node;
}

/** A small coloured label for an actor. */
export function chip(names, name) {
  return el("span", { class: "chip", style: `background:${actorColour(names, name)}` }, name || "—");
}
