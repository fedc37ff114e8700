// Where the page's data comes from: the viewer's server (/api/...), or, in a static export,
// the data/*.js scripts that hand it over with SW.put(name, data).
"use strict";
window.SW = (() => {
  const store = {};
  const waiting = {};
  function put(name, data) {
    store[name] = data;
    (waiting[name] || []).forEach((resolve) => resolve(data));
    delete waiting[name];
  }
  function loadScript(src, name) {
    if (name in store) return Promise.resolve(store[name]);
    return new Promise((resolve, reject) => {
      (waiting[name] = waiting[name] || []).push(resolve);
      const tag = document.createElement("script");
      tag.src = src;
      tag.onerror = () => reject(new Error("could not load " + src));
      document.head.appendChild(tag);
    });
  }
  const isStatic = () => "static" in store;
  async function getJSON(url) {
    const answer = await fetch(url);
    if (!answer.ok) throw new Error(url + ": " + answer.status + " " + (await answer.text()));
    return answer.json();
  }
  const api = {
    isStatic,
    runs: () => isStatic() ? loadScript("data/runs.js", "runs") : getJSON("api/runs"),
    scenario: (key) => {
      if (!isStatic()) return getJSON("api/scenario?key=" + encodeURIComponent(key));
      const id = store.static.ids[key];
      if (!id) return Promise.reject(new Error("no scenario " + key + " in this export"));
      return loadScript("data/" + id + ".js", "scenario:" + key);
    },
    file: async (key, name) => {
      if (isStatic()) return (await api.scenario(key)).file_texts[name];
      const answer = await fetch("api/file?key=" + encodeURIComponent(key) + "&name=" + encodeURIComponent(name));
      return answer.text();
    },
  };
  return { put, api, store };
})();
