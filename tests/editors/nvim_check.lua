-- Run by tests/editors/test_neovim.py after an editor set-up of docs/editors.md: waits
-- for the language server's diagnostics in the open IL file, then starts the debug
-- adapter exactly as the nvim-dap snippet configures it and waits for its answer to
-- initialize; writes what it saw to $ASICTL_NVIM_OUT and quits.
local out = {}
local got = vim.wait(60000, function() return #vim.diagnostic.get(0) > 0 end, 100)
table.insert(out, "diagnostics " .. tostring(got))
for _, d in ipairs(vim.diagnostic.get(0)) do
  table.insert(out, string.format("%d: %s", d.lnum + 1, d.message))
end
local dap = require("dap")
local adapter = dap.adapters.asictl
local answer = ""
local job = vim.fn.jobstart({ adapter.command, unpack(adapter.args) }, {
  on_stdout = function(_, data) answer = answer .. table.concat(data, "\n") end,
})
local body = '{"seq": 1, "type": "request", "command": "initialize", "arguments": {}}'
vim.fn.chansend(job, "Content-Length: " .. #body .. "\r\n\r\n" .. body)
vim.wait(30000, function() return answer:find("supportsConfigurationDoneRequest", 1, true) ~= nil end, 50)
vim.fn.jobstop(job)
table.insert(out, "adapter " .. tostring(answer:find("supportsConfigurationDoneRequest", 1, true) ~= nil))
table.insert(out, "configurations " .. #dap.configurations.asi)
vim.fn.writefile(out, os.getenv("ASICTL_NVIM_OUT"))
vim.cmd("qa!")
