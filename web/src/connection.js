// The WebSocket to the server: JSON messages in and out, reconnecting every second after a close.

const RETRY_MS = 1000;

export class Connection {
  // handlers: {message(obj, text), open(), close()}
  constructor(url, handlers) {
    this.url = url;
    this.handlers = handlers;
    this.socket = null;
    this.connected = false;
    this.connect();
  }

  connect() {
    let socket;
    try {
      socket = new WebSocket(this.url);
    } catch (e) {
      this.scheduleRetry();
      return;
    }
    this.socket = socket;
    socket.onopen = () => {
      this.connected = true;
      this.handlers.open();
    };
    socket.onmessage = (event) => {
      if (typeof event.data !== 'string') return;
      let message;
      try {
        message = JSON.parse(event.data);
      } catch (e) {
        console.warn('rmpmarl view: a message that is not JSON', e);
        return;
      }
      this.handlers.message(message, event.data);
    };
    socket.onclose = () => {
      if (this.socket !== socket) return;
      const was = this.connected;
      this.connected = false;
      this.socket = null;
      this.handlers.close(was);
      this.scheduleRetry();
    };
    socket.onerror = () => {};  // onclose follows
  }

  scheduleRetry() {
    setTimeout(() => this.connect(), RETRY_MS);
  }

  // sends obj as JSON; false when not connected.
  send(obj) {
    if (!this.connected || this.socket.readyState !== WebSocket.OPEN) return false;
    this.socket.send(JSON.stringify(obj));
    return true;
  }
}
