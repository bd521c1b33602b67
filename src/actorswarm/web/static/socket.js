// The page's one WebSocket to the ground station: reconnects by itself, sends requests
// with an id of its own so the page can tell its commands' outcomes from other pages'.

export class Link {
  /** `onMessage(message)` for every message; `onState(up)` when the link goes up or down. */
  constructor(onMessage, onState) {
    this.onMessage = onMessage;
    this.onState = onState;
    this.ws = null;
    this.retry = 500;
    this.counter = 0;
    this.prefix = Math.random().toString(36).slice(2, 7);
  }

  url() {
    const scheme = location.protocol === "https:" ? "wss" : "ws";
    // The token of the page's address, if any, goes with the socket too.
    const token = new URLSearchParams(location.search).get("token");
    return `${scheme}://${location.host}/ws` + (token ? `?token=${encodeURIComponent(token)}` : "");
  }

  connect() {
    const ws = new WebSocket(this.url());
    this.ws = ws;
    ws.onopen = () => {
      this.retry = 500;
      this.onState(true);
    };
    ws.onmessage = (event) => {
      let message;
      try {
        message = JSON.parse(event.data);
      } catch {
        return;
      }
      this.onMessage(message);
    };
    ws.onclose = () => {
      this.onState(false);
      setTimeout(() => this.connect(), this.retry);
      this.retry = Math.min(this.retry * 2, 5000);
    };
  }

  /** Send a request; returns its id. */
  send(request) {
    const id = `${this.prefix}-${++this.counter}`;
    if (this.ws && this.ws.readyState === WebSocket.OPEN) {
      this.ws.send(JSON.stringify({ ...request, id }));
    }
    return id;
  }

  mine(id) {
    return typeof id === "string" && id.startsWith(this.prefix + "-");
  }
}
