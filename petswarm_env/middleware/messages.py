"""Frame types of the swarm middleware and their payload sizes (bytes, chosen).

Join protocol (seed 000 §3.4, Fig. 8), IR token ring (§3.3, Fig. 7), heading exchange and the
master's periodic broadcast (§3.5, Fig. 9), disperse (Fig. 4).
"""

SCAN = "scan"  # master -> waiting robots (broadcast; a rescan lists the robots already heard)
SCAN_RESPONSE = "scan_response"  # waiting robot -> master
JOIN_QUERY = "join_query"  # master -> joining candidates (broadcast, lists the candidates)
JOIN_ANSWER = "join_answer"  # candidate -> master: joining-available / joining-unavailable
JOIN_NOTIFY = "join_notify"  # master -> robot: new PAN ID, member number, total number of members
NON_PARTICIPATE = "non_participate"  # master -> robot: not selected, stay waiting
NOTIFY_ACK = "notify_ack"  # robot -> master

TX_START = "tx_start"  # token holder -> swarm: transmission-start sign
TX_START_ACK = "tx_start_ack"
TOKEN = "token"  # token holder -> swarm: the number of the next robot
TOKEN_ACK = "token_ack"
SYNC = "sync"  # next holder -> swarm: switching IR roles now
HEADING = "heading"  # neighbour of the transmitter -> transmitter: bearing it saw it at

STATUS = "status"  # master -> slaves: driving speed and user activity (periodic)
DISPERSE = "disperse"  # master -> slaves
DISPERSE_ACK = "disperse_ack"

MODE_CHANGE = "mode_change"  # master -> swarm: new driving mode, member and neighbour tables (Table 3)
MODE_CHANGE_ACK = "mode_change_ack"
HANDOVER = "handover"  # old master -> new master: take over the user connection
HANDOVER_ACK = "handover_ack"

SIZE_BYTES = {
    SCAN: 12,
    SCAN_RESPONSE: 4,
    JOIN_QUERY: 20,
    JOIN_ANSWER: 5,
    JOIN_NOTIFY: 24,
    NON_PARTICIPATE: 4,
    NOTIFY_ACK: 4,
    TX_START: 4,
    TX_START_ACK: 4,
    TOKEN: 6,
    TOKEN_ACK: 4,
    SYNC: 4,
    HEADING: 6,
    STATUS: 24,
    DISPERSE: 4,
    DISPERSE_ACK: 4,
    MODE_CHANGE: 40,
    MODE_CHANGE_ACK: 4,
    HANDOVER: 12,
    HANDOVER_ACK: 4,
}
